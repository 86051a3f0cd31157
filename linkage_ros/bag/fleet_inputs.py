"""The bags of a fleet run: several inputs, folders searched recursively, globs; and where each
bag's outputs go under ``--out-dir``.

A bag is a folder holding ``metadata.yaml`` (not searched further: its storage files are that
bag), or a ``.mcap`` / ``.db3`` file outside such a folder. A bag's name (its outputs' path
under ``--out-dir``, without the format's suffix) is its path relative to the input folder it
was found in, or its own name when it was given itself, with a storage file's ``.mcap`` /
``.db3`` dropped: ``fleet/day1/run3/`` -> ``day1/run3``, ``fleet/day1/b.mcap`` -> ``day1/b``.
A glob pattern's match is named from the pattern's leading folders (those before the first
with a wildcard): ``'archive/2026-*/**/*.mcap'`` matching ``archive/2026-01/l3/run.mcap``
-> ``2026-01/l3/run``.
"""

from __future__ import annotations

import glob
import os
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from .common import BagError
from .reading import STORAGE_SUFFIXES

#: --format choices and the suffix each adds to a bag's name (mcap and sqlite3 are bag folders)
FORMATS = ('csv', 'parquet', 'mcap', 'sqlite3', 'png', 'svg')

#: the file written last for each finished bag (its outputs are complete: see fleet_task)
MANIFEST_SUFFIX = '.done.json'

#: what a bag's recorded trajectories' and paths' CSV adds to its name
TRAJECTORIES_SUFFIX = '.trajectories.csv'

#: the fleet summary files in --out-dir
SUMMARY_NAMES = ('summary.csv', 'summary.json')


@dataclass(frozen=True)
class BagTask:
    """One bag to analyse: where it is, and its name under --out-dir (POSIX form)."""

    source: str  # absolute path of the bag folder or storage file
    name: str

    def output(self, out_dir: str, fmt: str) -> Path:
        """The path of this bag's output in ``fmt`` (a file, or a bag folder)."""
        return Path(out_dir, *PurePosixPath(self.name).parts[:-1], self.leaf + '.' + fmt)

    def manifest(self, out_dir: str) -> Path:
        return Path(out_dir, *PurePosixPath(self.name).parts[:-1], self.leaf + MANIFEST_SUFFIX)

    def trajectories(self, out_dir: str) -> Path:
        """The CSV of the recorded trajectories and paths (only with --trajectory/path-topic)."""
        return Path(out_dir, *PurePosixPath(self.name).parts[:-1], self.leaf + TRAJECTORIES_SUFFIX)

    @property
    def leaf(self) -> str:
        return PurePosixPath(self.name).name

    def owned_names(self) -> list[str]:
        """Every path under --out-dir (POSIX, relative) this bag may write or, with --resume,
        remove as its own leftover: its output in every format (not only this run's), its
        trajectories' CSV and its manifest."""
        names = [f'{self.name}.{fmt}' for fmt in FORMATS]
        return names + [self.name + TRAJECTORIES_SUFFIX, self.name + MANIFEST_SUFFIX]


def _is_bag_folder(p: Path) -> bool:
    return p.is_dir() and (p / 'metadata.yaml').is_file()


def _is_storage_file(p: Path) -> bool:
    return p.is_file() and p.suffix.lower() in STORAGE_SUFFIXES


def _storage_files(folder: Path) -> list[Path]:
    return [f for f in folder.iterdir() if _is_storage_file(f)]


def _bag_identity(bag: Path) -> str:
    """Which bag a found path is (resolved): a bag folder's only storage file is that folder's
    bag (the same messages, read once when both are given); one file of a split bag is a
    bag of its own (a part: find_bags refuses it beside its folder)."""
    resolved = bag.resolve()
    folder = resolved.parent
    if resolved.is_file() and _is_bag_folder(folder):
        try:
            if len(_storage_files(folder)) == 1:
                return str(folder)
        except OSError:  # (an unlistable folder: the file is taken as given)
            pass
    return str(resolved)


def _bag_name(rel: Path, is_file: bool) -> str:
    parts = list(rel.parts)
    if is_file:
        parts[-1] = parts[-1][: -len(rel.suffix)] or parts[-1]
    return '/'.join(parts)


def is_result_bag(p: Path) -> bool:
    """A fleet run's result bag: a bag folder NAME.mcap / NAME.sqlite3 beside the NAME.done.json
    its run wrote last (fleet_task)."""
    stem, dot, fmt = p.name.rpartition('.')
    manifest = p.parent / (stem + MANIFEST_SUFFIX)
    return bool(dot) and fmt in ('mcap', 'sqlite3') and manifest.is_file()


def bags_in(folder: Path, results: list[Path] | None = None) -> list[tuple[Path, str]]:
    """Every bag under ``folder`` (recursively, sorted, symlinked folders not followed), but an
    earlier run's result bags (is_result_bag: appended to ``results`` where given)."""
    found: list[tuple[Path, str]] = []

    def fail(exc: OSError) -> None:
        raise BagError(f'input {folder}: cannot list {exc.filename} ({exc.strerror or exc})')

    for root, dirs, files in os.walk(folder, onerror=fail):
        here = Path(root)
        dirs.sort()
        keep = []
        for d in dirs:
            if _is_bag_folder(here / d) and is_result_bag(here / d):
                if results is not None:
                    results.append(here / d)
            elif _is_bag_folder(here / d):
                found.append((here / d, _bag_name((here / d).relative_to(folder), False)))
            else:
                keep.append(d)
        dirs[:] = keep
        for f in sorted(files):
            p = here / f
            if _is_storage_file(p):
                found.append((p, _bag_name(p.relative_to(folder), True)))
    return found


def _expand(item: str) -> list[tuple[str, Path | None]]:
    """A glob pattern's matches (``**`` for any depth), each with the folder its name is taken
    relative to (the pattern's leading folders, before the first with a wildcard); or the item
    itself (None) when it names an existing path or has no pattern characters."""
    if os.path.lexists(item) or not glob.has_magic(item):
        return [(item, None)]
    fixed = []
    for part in Path(item).parts[:-1]:
        if glob.has_magic(part):
            break
        fixed.append(part)
    base = Path(*fixed) if fixed else Path('.')
    if '**' in Path(item).parts:
        matches = _any_depth(base, Path(item).parts[len(fixed) :])
    else:
        matches = sorted(glob.glob(item))
    if not matches:
        raise BagError(f'input {item}: the pattern matches nothing')
    return [(m, base) for m in matches]


def _any_depth(base: Path, rest: Sequence[str]) -> list[str]:
    """The matches of the pattern ``rest`` (holding ``**``) under ``base``, symlinked folders
    not followed (as a folder input's search): glob.glob's ``**`` follows them, and a link to
    a folder above (``up -> ..``) made its search endless (an adversary). Names starting
    with a dot are matched only by a pattern part starting with one, as glob.glob's."""
    dotted = any(part.startswith('.') for part in rest)
    # ('r1**' is 'r1*' as glob.glob reads it; pathlib takes ** only as a whole part)
    rest = [part if part == '**' else re.sub(r'\*\*+', '*', part) for part in rest]
    found = []
    for p in base.glob('/'.join(rest)):
        if not dotted and any(q.startswith('.') for q in p.relative_to(base).parts):
            continue
        found.append(str(p) if str(base) != '.' else str(p.relative_to(base)))
    return sorted(found)


class _OutputOwners:
    """The paths under --out-dir the bags found so far own (BagTask.owned_names), to refuse
    a bag whose outputs would overwrite another's before any work: two bags of one name, but
    also bag ``x``'s ``x.trajectories.csv`` against bag ``x.trajectories``'s CSV, or bag
    ``x``'s result bag folder ``x.mcap/`` against bag ``x.mcap/y``'s outputs inside it."""

    def __init__(self) -> None:
        self.owner: dict[str, BagTask] = {}  # owned path -> its bag
        self.folder_of: dict[str, BagTask] = {}  # a folder holding an owned path -> its bag

    def claim(self, task: BagTask) -> None:
        """Record ``task``'s paths; BagError if another bag owns one of them, a folder one of
        them lies in, or a path inside one of them."""
        owned = task.owned_names()
        for path in owned:
            above = [str(f) for f in PurePosixPath(path).parents if str(f) != '.']
            outer = next((f for f in above if f in self.owner), None)
            if path in self.owner:
                other, clash = self.owner[path], f'two bags would write the same output {path}'
            elif path in self.folder_of:  # (another's outputs lie in this one)
                other, clash = self.folder_of[path], f"one bag's outputs would lie in {path}"
            elif outer is not None:
                other, clash = self.owner[outer], f"one bag's outputs would lie in {outer}"
            else:
                continue
            if other.name == task.name:
                raise BagError(
                    f'two bags would write the same outputs {task.name}.*: {other.source} and '
                    f'{task.source} (rename one, or give the folder above them both: names '
                    'are taken from the folder given)'
                )
            raise BagError(
                f'{clash}: {other.source} (named {other.name}) and {task.source} (named '
                f'{task.name}); a bag named N writes N.<format>, N{TRAJECTORIES_SUFFIX} and '
                f'N{MANIFEST_SUFFIX} (rename one)'
            )
        for path in owned:
            self.owner[path] = task
            for f in PurePosixPath(path).parents:
                if str(f) != '.':
                    self.folder_of[str(f)] = task


def _inside_out_dir(path: str, name: str) -> None:
    """BagError where a bag's name would put its outputs outside --out-dir: a pattern whose
    match climbs out of the pattern's folder (``'bags/*/../../x/*.mcap'`` named a bag
    ``basic/../../x/b``, whose CSV overwrote ``x/b.csv`` beside the input: an adversary)."""
    parts = PurePosixPath(name).parts
    if not parts or PurePosixPath(name).is_absolute() or any(q in ('..', '.') for q in parts):
        raise BagError(
            f'input {path}: its outputs would be named {name!r} under --out-dir, which leaves '
            'it (a pattern climbing out of its own folder with ..): give the bag or its folder '
            'itself, or a pattern without ..'
        )


def find_bags(
    inputs: Sequence[str], skip: Path | None = None, results: list[Path] | None = None
) -> list[BagTask]:
    """The bags of the inputs in the order given (each folder's in sorted order), each once
    (a bag folder and its only storage file are one bag: the first given is kept);
    of a folder's or a pattern's, none from under the folder ``skip`` (resolved: the run's
    --out-dir, whose result bags are not inputs; a bag named itself is kept, for the caller
    to refuse), nor an earlier run's result bag (is_result_bag: appended to ``results``);
    BagError for a missing input, a folder holding no bag, two bags whose
    outputs would share a path (_OutputOwners), or a split bag's folder beside one of its
    storage files."""

    def kept(found: list[tuple[Path, str]]) -> list[tuple[Path, str]]:
        if skip is None:
            return found
        return [(bag, name) for bag, name in found if skip not in bag.resolve().parents]

    tasks: list[BagTask] = []
    seen: set[str] = set()  # the bags taken (_bag_identity)
    owners = _OutputOwners()
    for item in inputs:
        for path, base in _expand(item):
            p = Path(path)
            if not p.exists():
                raise BagError(f'input {path}: no such file or folder')
            # a match of a pattern is named from the pattern's folder (two days' run/ apart)
            # a bag given itself is named after its real folder, also as '.' or '..' (whose
            # name is '' or '..'), without following a symlink to another name
            at = Path(Path(os.path.abspath(p)).name) if base is None else p.relative_to(base)
            if _is_bag_folder(p) or _is_storage_file(p):
                found = [(p, _bag_name(at, p.is_file()))]
                if base is not None:  # (a pattern's match: not an earlier run's result bag)
                    bag = p.parent if p.is_file() and _is_bag_folder(p.parent) else p
                    if is_result_bag(bag):
                        if results is not None and bag not in results:
                            results.append(bag)
                        continue
                    found = kept(found)
            elif p.is_dir():
                found = kept(bags_in(p, results))
                if base is not None:
                    found = [(bag, f'{at.as_posix()}/{name}') for bag, name in found]
                if not found:
                    raise BagError(
                        f'input {path}: no bag in this folder or below (a bag is a folder '
                        'with metadata.yaml, or a .mcap or .db3 file)'
                    )
            else:
                raise BagError(
                    f'input {path}: not a rosbag2 (expected a bag folder, a .mcap or a .db3 '
                    'file, or a folder holding bags)'
                )
            for bag, name in found:
                _inside_out_dir(path, name)
                identity = _bag_identity(bag)
                if identity in seen:
                    continue
                task = BagTask(str(bag.resolve()), name)
                owners.claim(task)
                seen.add(identity)
                tasks.append(task)
    if not tasks:
        raise BagError('no bag given')
    for t in tasks:  # (a part of a split bag beside the whole: its messages counted twice)
        folder = Path(t.source).parent
        if str(folder) in seen and _bag_identity(Path(t.source)) != str(folder):
            raise BagError(
                f'input {t.source} is one storage file of the bag {folder}, also given: give '
                'the bag folder or its files, not both (their messages would be counted twice)'
            )
    return tasks
