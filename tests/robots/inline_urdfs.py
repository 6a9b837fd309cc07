"""URDF texts shared by the robots tests (client-style models)."""

from __future__ import annotations


def joint(
    name, parent, child, jtype="revolute", xyz="0 0 0", rpy="0 0 0", axis="0 0 1", limit=None
):
    lim = (
        limit
        if limit is not None
        else (
            '<limit lower="-3" upper="3" velocity="2" effort="1"/>'
            if jtype in ("revolute", "prismatic")
            else ""
        )
    )
    ax = f'<axis xyz="{axis}"/>' if jtype != "fixed" else ""
    return (
        f'<joint name="{name}" type="{jtype}"><parent link="{parent}"/><child link="{child}"/>'
        f'<origin xyz="{xyz}" rpy="{rpy}"/>{ax}{lim}</joint>'
    )


def robot(*parts: str, links: list[str]) -> str:
    body = "".join(f'<link name="{n}"/>' for n in links)
    return f'<?xml version="1.0"?>\n<robot name="client">{body}{"".join(parts)}</robot>'


# A 4-dof arm on a mount offset and rotated from the URDF root, with a prismatic joint, a continuous
# wrist, a two-finger gripper (not on the chain) and a mesh the service must never load.
OFFSET_BASE_URDF = robot(
    joint("world_to_mount", "world", "mount", "fixed", xyz="0.5 -0.2 0.3", rpy="0.3 -0.2 1.0"),
    joint("j1", "mount", "l1", xyz="0 0 0.2", axis="0 0 1"),
    joint("j2", "l1", "l2", xyz="0 0.1 0.3", rpy="1.5707963267948966 0 0", axis="0 1 1"),
    joint(
        "slide",
        "l2",
        "l3",
        "prismatic",
        xyz="0.4 0 0",
        axis="1 0 0",
        limit='<limit lower="0" upper="0.3" velocity="0.5" effort="1"/>',
    ),
    joint("wrist", "l3", "l4", "continuous", xyz="0 0 0.1", axis="0 -1 0"),
    joint("tool_fixed", "l4", "tool", "fixed", xyz="0 0 0.05", rpy="0 0.5 0"),
    joint(
        "finger_a",
        "l4",
        "fa",
        "prismatic",
        axis="0 1 0",
        limit='<limit lower="0" upper="0.04" velocity="0.1" effort="1"/>',
    ),
    joint(
        "finger_b",
        "l4",
        "fb",
        "prismatic",
        axis="0 -1 0",
        limit='<limit lower="0" upper="0.04" velocity="0.1" effort="1"/>',
    ),
    links=["world", "mount", "l1", "l2", "l3", "l4", "tool", "fa", "fb"],
).replace(
    '<link name="l1"/>',
    '<link name="l1"><visual><geometry><mesh filename="package://nowhere/l1.stl"/></geometry>'
    '</visual><collision><geometry><mesh filename="file:///etc/passwd"/></geometry></collision>'
    "</link>",
)

PLANAR_3R_URDF = robot(
    joint("a", "base", "l1", axis="0 0 1"),
    joint("b", "l1", "l2", xyz="0.5 0 0", axis="0 0 1"),
    joint("c", "l2", "l3", xyz="0.4 0 0", axis="0 0 -1"),
    joint("t", "l3", "tip", "fixed", xyz="0.3 0 0"),
    links=["base", "l1", "l2", "l3", "tip"],
)


def chain(n: int) -> str:
    """An n-joint revolute chain l0 -> l1 -> ... -> ln."""
    return robot(
        *(joint(f"j{i}", f"l{i}", f"l{i + 1}", xyz="0 0 0.01") for i in range(n)),
        links=[f"l{i}" for i in range(n + 1)],
    )
