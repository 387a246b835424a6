"""Result folders: created empty (`prepare_output_dir`), built in a hidden sibling and swapped in whole
(`staged_output`; what other commands wrote into the folder it replaces is carried over, `carry_over`), or resumed in place by a sweep (`resumable_output`). Each first settles what killed
commands left beside NAME (storage.leftovers) and refuses to replace what liaison did not write
(storage.ownership)."""

import errno
import logging
import os
import shutil
import tempfile
from contextlib import contextmanager
from pathlib import Path

from liaison_cli import interrupts
from liaison_cli.errors import OutputExistsError
from liaison_cli.storage.atomic import current_umask
from liaison_cli.storage.leftovers import recover_output
from liaison_cli.storage.locks import FolderBusy, claim, writer_lock
from liaison_cli.storage.ownership import RESULT_MARKER, check_replaceable, is_ours, mark_ours
from liaison_cli.storage.swap import swap_in


def prepare_output_dir(path, overwrite: bool) -> Path:
    """An empty output folder at `path` (replacing a previous liaison result only with `overwrite`)."""
    path = Path(path)
    recover_output(path)
    if check_replaceable(path, overwrite):
        shutil.rmtree(path)
    _make_parent(path)
    path.mkdir(exist_ok=True)
    mark_ours(path)
    return path


def _make_parent(path: Path) -> None:
    """mkdir -p of the parent, naming the component that is a file (ENOTDIR) instead of 'File exists'."""
    for ancestor in reversed(path.parents):
        if ancestor.exists() and not ancestor.is_dir():
            raise NotADirectoryError(errno.ENOTDIR, os.strerror(errno.ENOTDIR), str(ancestor))
    path.parent.mkdir(parents=True, exist_ok=True)


def carry_over(old: Path, stage: Path) -> list[str]:
    """Link into the stage every entry of the result folder `old` that the new result does not write (another
    command's output: `plots/`, an export's `ccsds-run<K>/`, a user's notes), so replacing a result deletes only
    what the replacing command writes again. Hard links (a copy where the file system has none): the old
    folder stays whole until the swap, so a kill before it loses nothing. Returns the names carried over."""
    if not old.is_dir() or old.is_symlink():
        return []
    kept = []
    for entry in sorted(old.iterdir()):
        target = stage / entry.name
        if entry.name == RESULT_MARKER or target.exists() or target.is_symlink():
            continue
        if entry.is_dir() and not entry.is_symlink():
            shutil.copytree(entry, target, symlinks=True, copy_function=_link_or_copy)
        else:
            _link_or_copy(entry, target)
        kept.append(entry.name + ("/" if entry.is_dir() and not entry.is_symlink() else ""))
    return kept


def _link_or_copy(source, destination) -> None:
    if os.path.islink(source):
        os.symlink(os.readlink(source), destination)
        return
    try:
        os.link(source, destination)
    except OSError:
        shutil.copy2(source, destination)


@contextmanager
def _no_other_writer(path: Path):
    """Hold the folder's writer lock (storage.locks.writer_lock) for the block; another holder (a sweep writing
    into the folder) is one line, exit 2. Where the lock file cannot be made (a read-only parent), no sweep can
    be writing there either: the block runs, and the write itself names the OS's reason."""
    lock = writer_lock(path)
    try:
        lock.__enter__()
    except FolderBusy:
        raise OutputExistsError(f"{path}: another liaison command (a sweep) is writing into this folder; wait for it "
                                "to finish or choose --output") from None
    except OSError:
        yield
        return
    try:
        yield
    finally:
        lock.__exit__(None, None, None)


@contextmanager
def staged_output(path, overwrite: bool):
    """Yield a sibling temporary folder to write a result into; when the block completes, it takes the
    place of `path` (a previous liaison result there is swapped out, then removed). A failed or killed
    run leaves `path` as it was, and at most a hidden `.NAME.partial-PID-*` folder beside it, which the next
    command writing `path` removes (recover_output)."""
    path = Path(path)
    recover_output(path)
    replace = check_replaceable(path, overwrite)
    _make_parent(path)
    with _no_other_writer(path):  # refused before any work when a sweep is writing there now
        pass
    try:
        # The pid in the name and the flock held on the folder tell a later command it is in use.
        stage = Path(tempfile.mkdtemp(prefix=f".{path.name}.partial-{os.getpid()}-", dir=path.parent))
    except OSError as exc:  # read-only, no permission, full: say where the result was to go
        raise OSError(exc.errno, exc.strerror, str(path)) from exc
    try:
        with claim(stage, wait=True):
            mark_ours(stage)  # from the start, so a killed run's folder is known as ours and cleaned
            yield stage
            if interrupts.requested():  # Ctrl-C that compiled code swallowed: the old result stays
                raise KeyboardInterrupt
            os.chmod(stage, 0o777 & ~current_umask())
            with _no_other_writer(path):  # held across the swap: no sweep starts writing `path` meanwhile (a
                kept = carry_over(path, stage) if replace else []  # kill here leaves the lock file, which the
                swap_in(stage, path, replace)  # next writer's recover_output removes)
            if kept:  # other commands' outputs (plots, exports) made from the result this one replaced
                logging.getLogger("liaison").warning(
                    f"{path}: kept from the result it replaced: {', '.join(kept)} (made from that result: rerun "
                    "`liaison plot run` or `liaison export` to remake them)")
            interrupts.result_written(path)
    except OSError as exc:
        with interrupts.noted_not_raised():  # a Ctrl-C now must not leave the staging folder half-removed
            shutil.rmtree(stage, ignore_errors=True)
        if exc.filename is not None and str(exc.filename).startswith(str(stage)):
            # Name the file as the user knows it; the staging folder is gone.
            destination = path / Path(exc.filename).relative_to(stage)
            raise OSError(exc.errno, exc.strerror, str(destination)) from exc
        raise
    except BaseException:
        with interrupts.noted_not_raised():
            shutil.rmtree(stage, ignore_errors=True)
        raise


@contextmanager
def resumable_output(path, overwrite: bool, key: str):
    """Yield the folder a resumable job (a sweep, whose manifest records what is done) writes into.

    Without `overwrite`, or with nothing to replace: `path` itself (an existing liaison folder is resumed;
    a non-empty folder that is not, refused). With `overwrite` of an existing liaison result: a hidden
    sibling `.NAME.replacing-KEY`, swapped in when the block completes and kept if it is interrupted, so the
    same command (same `key`) resumes it while the old result stays in place until then.
    """
    path = Path(path)
    recover_output(path)
    if not overwrite or not check_replaceable(path, overwrite):
        if not (path / "manifest.jsonl").exists():
            prepare_output_dir(path, overwrite=False)
        yield path
        return
    stage = path.parent / f".{path.name}.replacing-{key}"
    if stage.exists() and not is_ours(stage) and any(stage.iterdir()):
        raise OutputExistsError(f"{stage}: not a liaison folder; remove it yourself or choose --output")
    stage.mkdir(exist_ok=True)
    mark_ours(stage)
    yield stage
    swap_in(stage, path, replace=True)
