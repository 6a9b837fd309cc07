"""Print the installed distributions that only the given ones bring: the Dockerfile's builder stage
uninstalls them (``pip uninstall -y $(python exclusive_requirements.py urchin)``).

EAIK requires ``urchin`` (its URDF loader, ``eaik.IK_URDF``) and through it a mesh and graphics
stack: trimesh, pyribbit, pyglet, PyOpenGL, pillow, imageio, freetype-py, lxml, networkx,
pycollada ... (about 93 MB). The service calls ``eaik.pybindings`` only, from the joint axes it
computes itself, so none of that stack is ever imported; a Python package cannot declare "EAIK
without its requirements", so the image removes them after ``pip install .``.

``python exclusive_requirements.py ROOT...`` prints, one per line, ROOT and every distribution in
its requirement closure that no installed distribution outside that closure requires (so a
package another part of the service needs, such as numpy or scipy, stays). Standard library only.
"""

from __future__ import annotations

import importlib.metadata as metadata
import re
import sys


def _key(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def _requirements(dist: metadata.Distribution) -> set[str]:
    """Names of ``dist``'s requirements, without those of extras. Any other environment marker is
    taken to hold: a requirement counted that does not apply can only keep a package."""
    names = set()
    for requirement in dist.requires or []:
        spec, _, marker = requirement.partition(";")
        if "extra" not in marker:
            names.add(_key(re.split(r"[<>=!~\[ (]", spec.strip(), maxsplit=1)[0]))
    return names


def exclusive(roots: list[str]) -> list[str]:
    installed = {_key(d.metadata["Name"]): d for d in metadata.distributions()}
    graph = {name: _requirements(dist) & installed.keys() for name, dist in installed.items()}
    closure: set[str] = set()
    todo = [_key(r) for r in roots if _key(r) in installed]
    while todo:
        name = todo.pop()
        if name not in closure:
            closure.add(name)
            todo.extend(graph[name])
    # Drop, until nothing changes, every member some distribution outside the closure requires.
    changed = True
    while changed:
        needed = {req for name in installed.keys() - closure for req in graph[name]}
        kept = closure - needed - {_key(r) for r in roots}
        changed = kept != closure - {_key(r) for r in roots}
        closure = kept | ({_key(r) for r in roots} & installed.keys())
    return sorted(installed[name].metadata["Name"] for name in closure)


if __name__ == "__main__":
    if len(sys.argv) < 2:
        print("usage: python exclusive_requirements.py DISTRIBUTION...", file=sys.stderr)
        sys.exit(2)
    print("\n".join(exclusive(sys.argv[1:])))
