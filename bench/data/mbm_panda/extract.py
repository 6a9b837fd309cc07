"""Extract MotionBenchMaker Panda problems into ``problems.json`` (what ``bench.mbm`` reads).

Usage: ``python bench/data/mbm_panda/extract.py <problems dir> [count]``, where ``<problems dir>``
holds ``<scenario>_panda/scene####.yaml`` and ``request####.yaml`` (VAMP's
``resources/panda/problems.tar.bz2``, unpacked); problems 1..count (default 15) of each scenario.

Kept as in the files: each collision object's id, primitive type and ``dimensions`` (MoveIt's
``SolidPrimitive``: box = full side lengths, sphere = [radius], cylinder = [height, radius]) and
its ``primitive_poses[0]`` (position, orientation x y z w) in the planning frame, which is the
robot's base ``panda_link0`` in every scene (identity virtual joint and fixed frames; checked
here); the start's 7 arm joints; the goal's joint constraints in joint order.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import yaml

SCENARIOS = ("table_pick", "table_under_pick", "box", "bookshelf_small", "bookshelf_tall",
             "bookshelf_thin", "cage")  # fmt: skip
JOINTS = tuple(f"panda_joint{i}" for i in range(1, 8))
IDENTITY = {"translation": [0, 0, 0], "rotation": [0, 0, 0, 1]}


def problem(folder: Path, index: int) -> dict:
    scene = yaml.safe_load((folder / f"scene{index:04d}.yaml").read_text())
    request = yaml.safe_load((folder / f"request{index:04d}.yaml").read_text())
    frames = scene["robot_state"]["multi_dof_joint_state"]["transforms"]
    frames += [f["transform"] for f in scene.get("fixed_frame_transforms", [])]
    if any(f != IDENTITY for f in frames):
        raise ValueError(f"{folder.name} {index}: the planning frame is not the robot's base")
    obstacles = []
    for obj in scene["world"]["collision_objects"]:
        if "pose" in obj or len(obj["primitives"]) != 1:
            raise ValueError(f"{folder.name} {index}: object {obj['id']} is not one primitive")
        prim, pose = obj["primitives"][0], obj["primitive_poses"][0]
        obstacles.append({"id": obj["id"], "type": prim["type"], "dimensions": prim["dimensions"],
                          "position": pose["position"], "orientation": pose["orientation"]})  # fmt: skip
    state = request["start_state"]["joint_state"]
    start = [float(state["position"][state["name"].index(j)]) for j in JOINTS]
    goal_by_name = {
        c["joint_name"]: float(c["position"])
        for c in request["goal_constraints"][0]["joint_constraints"]
    }
    return {"index": index, "start": start, "goal": [goal_by_name[j] for j in JOINTS],
            "obstacles": obstacles}  # fmt: skip


def main() -> None:
    root, count = Path(sys.argv[1]), int(sys.argv[2]) if len(sys.argv) > 2 else 15
    out = {s: [problem(root / f"{s}_panda", i) for i in range(1, count + 1)] for s in SCENARIOS}
    target = Path(__file__).with_name("problems.json")
    target.write_text(json.dumps(out, separators=(",", ":")) + "\n")
    print(f"wrote {sum(len(v) for v in out.values())} problems to {target}")


if __name__ == "__main__":
    main()
