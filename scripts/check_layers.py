#!/usr/bin/env python3
"""Checks that #include "..." runs one way through Tessera's layers (docs/ARCHITECTURE.md):

    sampling -> scheduler -> renderer/util -> renderer/input
             -> renderer/shading | renderer/lights | renderer/camera -> renderer/scene
             -> renderer/integrators -> renderer/app

A file may include its own layer and the layers before it; shading, lights and camera are
siblings and do not include each other. Within a layer, no two files include each other's sides
(a.h or a.cpp including b.h while b.h or b.cpp includes a.h): such a pair is one unit in two
files, or needs a third header below both. Prints every include that breaks the rule as
`file:line: includes X (layer A may not include layer B)` and exits 1; exits 0 when there is none.

    scripts/check_layers.py [ROOT]
"""
import pathlib
import re
import sys

RANK = {
    'sampling': 0, 'scheduler': 1,
    'renderer/util': 2, 'renderer/input': 3,
    'renderer/shading': 4, 'renderer/lights': 4, 'renderer/camera': 4,
    'renderer/scene': 5, 'renderer/integrators': 6, 'renderer/app': 7,
}
INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"')


def layer_of(rel):
    """The layer of a repository-relative path, or None outside the layered folders."""
    parts = rel.split('/')
    if parts[0] in ('sampling', 'scheduler'):
        return parts[0]
    if parts[0] == 'renderer' and len(parts) >= 3:
        key = '/'.join(parts[:2])
        return key if key in RANK else None
    return None


def main():
    root = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else
                        pathlib.Path(__file__).resolve().parent.parent)
    problems, checked = [], 0
    uses = {}  # unit (path without extension) -> {included unit: "file:line"}
    for folder in ('sampling', 'scheduler', 'renderer'):
        for path in sorted((root / folder).rglob('*')):
            if path.suffix not in ('.h', '.cpp'):
                continue
            rel = path.relative_to(root).as_posix()
            mine = layer_of(rel)
            if mine is None:
                problems.append(f'{rel}:1: not in any layer ({", ".join(RANK)})')
                continue
            for n, line in enumerate(path.read_text(encoding='utf-8').splitlines(), 1):
                m = INCLUDE.match(line)
                if not m:
                    continue
                checked += 1
                unit, other = rel.rsplit('.', 1)[0], m.group(1).rsplit('.', 1)[0]
                if other != unit:
                    uses.setdefault(unit, {}).setdefault(other, f'{rel}:{n}')
                theirs = layer_of(m.group(1))
                if theirs is None:
                    if m.group(1).startswith(('sampling/', 'scheduler/', 'renderer/')):
                        problems.append(f'{rel}:{n}: includes {m.group(1)}, which is in no layer')
                    continue
                if theirs == mine:
                    continue
                if RANK[theirs] >= RANK[mine]:
                    problems.append(f'{rel}:{n}: includes {m.group(1)} '
                                    f'(layer {mine} may not include layer {theirs})')
    for unit, others in sorted(uses.items()):
        for other, where in sorted(others.items()):
            if unit < other and unit in uses.get(other, {}):
                problems.append(f'{where}: {unit} and {other} include each other '
                                f'(also {uses[other][unit]})')
    for p in problems:
        print(p)
    print(f'check_layers: {checked} includes checked, {len(problems)} out of order')
    return 1 if problems else 0


if __name__ == '__main__':
    sys.exit(main())
