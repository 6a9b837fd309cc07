"""Draw the shipped robots' collision capsules at their home poses: ``python docs/figures/collision_geometry.py`` (from the project root)
writes ``docs/collision_geometry.png`` (side views; the figure of docs/robots.md "Collision geometry").

Needs matplotlib, a development tool and not a service dependency: the service never imports this.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the project root: robots/

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pinocchio as pin
from matplotlib.patches import Circle

from robots import registry
from robots.geometry import ROBOT_GEOMETRY


def main(path: str = "docs/collision_geometry.png") -> None:
    fig, axes = plt.subplots(1, 4, figsize=(16, 4.6))
    colors = plt.cm.tab10.colors  # type: ignore[attr-defined]
    for ax, name in zip(axes, ["planar_2r", "puma560", "ur5", "panda"], strict=True):
        robot = registry.get(name)
        q = robot.home
        h, v = (0, 1) if name == "planar_2r" else (0, 2)
        links: list[str] = []
        for c in ROBOT_GEOMETRY[name].capsules:
            if c.link not in links:
                links.append(c.link)
            T = robot.frame_pose(q, c.link)
            a = T[:3, :3] @ np.array(c.a) + T[:3, 3]
            b = T[:3, :3] @ np.array(c.b) + T[:3, 3]
            col = colors[links.index(c.link) % 10]
            for s in np.linspace(0, 1, 30):  # the capsule's shadow: discs along its axis
                p = a + s * (b - a)
                ax.add_patch(Circle((p[h], p[v]), c.radius, color=col, alpha=0.12, lw=0))
            ax.plot([a[h], b[h]], [a[v], b[v]], color=col, lw=1.5, label=c.link)
        data = pin.Data(robot.model)
        pin.forwardKinematics(robot.model, data, q)
        R, t = robot.chain.T_base_world[:3, :3], robot.chain.T_base_world[:3, 3]
        joints = [R @ data.oMi[j].translation + t for j in range(robot.model.njoints)]
        pts = np.array([*joints, robot.fk(q)[:3, 3]])
        ax.plot(pts[:, h], pts[:, v], "k.-", lw=1, ms=5)  # the kinematic skeleton
        ax.set_aspect("equal")
        ax.grid(alpha=0.3)
        ax.set_title(f"{name} at home")
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]" if name == "planar_2r" else "z [m]")
        handles, labels = ax.get_legend_handles_labels()
        unique = dict(zip(labels, handles, strict=True))
        ax.legend(unique.values(), unique.keys(), fontsize=6, loc="best")
        ax.autoscale_view()
    fig.tight_layout()
    fig.savefig(path, dpi=90)


if __name__ == "__main__":
    main(*sys.argv[1:])
