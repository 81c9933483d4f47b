#!/usr/bin/env python3
"""Checks that #include "..." runs one way through Tessera's layers (docs/ARCHITECTURE.md):

    sampling -> scheduler -> renderer/util -> renderer/input
             -> renderer/shading | renderer/lights | renderer/camera -> renderer/media
             -> renderer/scene -> renderer/integrators -> renderer/app

A file may include its own layer and the layers before it; shading, lights and camera are
siblings and do not include each other. Within a layer, no two files include each other's sides
(a.h or a.cpp including b.h while b.h or b.cpp includes a.h): such a pair is one unit in two
files, or needs a third header below both. Prints every include that breaks the rule as
`file:line: includes X (layer A may not include layer B)` and exits 1; exits 0 when there is none.

    scripts/check_layers.py [ROOT]
    scripts/check_layers.py --self-test   the checker finds what it must (a temporary tree)
"""
import pathlib
import re
import sys

RANK = {
    'sampling': 0, 'scheduler': 1,
    'renderer/util': 2, 'renderer/input': 3,
    'renderer/shading': 4, 'renderer/lights': 4, 'renderer/camera': 4,
    'renderer/media': 5, 'renderer/scene': 6, 'renderer/integrators': 7, 'renderer/app': 8,
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


def self_test():
    """Runs the check on small trees with one known fault each; 0 when every fault is found."""
    import tempfile
    cases = {  # file -> text, and the words the report must contain
        'upward': ({'renderer/util/a.h': '#include "renderer/scene/b.h"\n',
                    'renderer/scene/b.h': ''}, 'may not include layer renderer/scene'),
        'sibling': ({'renderer/lights/a.h': '#include "renderer/camera/b.h"\n',
                     'renderer/camera/b.h': ''}, 'may not include layer renderer/camera'),
        'cycle': ({'renderer/input/a.h': '#include "renderer/input/b.h"\n',
                   'renderer/input/b.cpp': '#include "renderer/input/a.h"\n',
                   'renderer/input/b.h': ''}, 'include each other'),
        'stray': ({'renderer/x.cpp': ''}, 'not in any layer'),
    }
    failed = 0
    for name, (files, expect) in cases.items():
        with tempfile.TemporaryDirectory() as d:
            for rel, text in files.items():
                path = pathlib.Path(d, rel)
                path.parent.mkdir(parents=True, exist_ok=True)
                path.write_text(text)
            problems = check(pathlib.Path(d))
            if not any(expect in p for p in problems):
                print(f'self-test {name}: expected "{expect}", got {problems}')
                failed += 1
    good = check(pathlib.Path(tempfile.mkdtemp()))
    if good:
        print(f'self-test: an empty tree reports {good}')
        failed += 1
    print(f'check_layers self-test: {len(cases) + 1 - failed} of {len(cases) + 1} cases right')
    return 1 if failed else 0


def main():
    if sys.argv[1:] == ['--self-test']:
        return self_test()
    root = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else
                        pathlib.Path(__file__).resolve().parent.parent)
    problems = check(root)
    for p in problems:
        print(p)
    print(f'check_layers: {len(problems)} includes out of order')
    return 1 if problems else 0


def check(root):
    """Every problem of the tree at `root`, as "file:line: message" strings."""
    problems = []
    uses = {}  # unit (path without extension) -> {included unit: "file:line"}
    for folder in ('sampling', 'scheduler', 'renderer'):
        if not (root / folder).is_dir():
            continue
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
    return problems


if __name__ == '__main__':
    sys.exit(main())
