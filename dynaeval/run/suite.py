"""Many methods x many scenes in one run: ``dynaeval suite SUITE.toml`` (or ``ROOT --gt GT``).

A suite is a set of (method, scene) pairs, each a ``dynaeval score PRED GT``, with one set of
settings (``ScoreConfig`` fields) and one output folder ``OUT``. :func:`run_suite`:

1. prepares each scene's ground truth once (``dynaeval.run.prepare.prepare``) into
   ``OUT/prepared/<scene>`` (kept for the next run while the scene's files and the settings are
   the same: ``OUT/prepared/<scene>.key``);
2. scores every pair with ``prepared=`` (same numbers as a plain ``score``, faster) into
   ``OUT/results/<scene>__<method>.json``, and writes ``<scene>__<method>.key`` beside it last:
   the blake2b of the dynaeval version, the settings that change a number, the names and the
   digest of every PRED and GT file (and of a boxes file or detector model). A pair whose
   results and key are there with the same key is skipped: rerunning finishes only what is
   missing or changed;
3. writes the leaderboard of every scored pair, ranked by ``sort`` (``OUT/leaderboard.md``,
   ``.csv``, ``.json``; what each method costs from ``[costs]``, else from its run folder where
   a peer tool writes it: ``dynaeval.io.run_costs``) and one HTML page, ``OUT/index.html``, with
   the methods side by side per scene (``dynaeval.report.suite_page``).

A pair that fails (an unreadable frame, missing predictions) is recorded in the
:class:`SuiteOutcome` and the others still finish. Everything that can be checked before the work
starts is (the TOML, the folders, the settings, the output folder): ``InputError`` naming the
file, key or folder.

The work runs on an executor: by default in this process, one task after another (each with
``workers`` threads); or on anything with ``submit(fn, *args)`` (a Dask ``distributed.Client``:
``dynaeval suite ... --scheduler tcp://HOST:PORT``, or a ``concurrent.futures`` executor). Tasks
get paths, not pixels (every worker must see the folders at the same paths) and return the
results as a dict; the results and key files are written here, by the client, so a worker that
dies loses no result: Dask runs its tasks again elsewhere. A scene's pairs are submitted as soon
as its ground truth is prepared (they do not wait for the other scenes').

SUITE.toml (paths relative to the file)::

    output = "suite-out"
    [settings]                      # ScoreConfig fields
    metrics = ["psnr", "ssim"]
    focus = "motion"
    [scenes]
    stadium = "gt/stadium"          # scene = its ground-truth folder
    [methods]
    kplanes = "runs/kplanes/{scene}"            # one folder per scene ({scene}: its name)
    nerfplayer = {stadium = "runs/np-stadium"}  # or the scenes it has, by name
"""

from __future__ import annotations

import collections
import concurrent.futures
import json
import math
import re
import sys
import threading
import warnings
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path
from typing import Any

from dynaeval.core.deps import DEPENDENCIES, MissingDependency, load
from dynaeval.core.errors import InputError, did_you_mean
from dynaeval.core.progress import Progress
from dynaeval.core.version import VERSION
from dynaeval.io.atomic import check_writable, write_text_atomic
from dynaeval.io.jsonfile import MAX_DEPTH, nesting_depth
from dynaeval.io.lock import LOCK_NAME, hold_folder
from dynaeval.io.prepared import (
    FORMAT_VERSION,
    file_digest,
    folder_digests,
    json_digest,
    read_manifest,
)
from dynaeval.io.run_costs import read_run_costs
from dynaeval.metrics.registry import METRICS, SPECS
from dynaeval.regions.boxes_file import read_boxes_file
from dynaeval.report.leaderboard import COSTS, build_leaderboard, render
from dynaeval.report.results import load_results, results_text
from dynaeval.report.suite_page import render_suite_page
from dynaeval.run.config import ScoreConfig
from dynaeval.run.distributed import ScoreJob, score_shard
from dynaeval.run.evaluate import DynaevalWarning
from dynaeval.run.prepare import prepare

__all__ = ["Suite", "SuiteOutcome", "SuitePair", "folder_suite", "load_suite", "read_toml",
           "run_suite", "settings_config"]

FIXED_FIELDS = ("method", "scene", "prepared", "shard", "progress")
"""``ScoreConfig`` fields a suite sets itself (names from the suite, its own prepared folders,
its own bar): refused in ``[settings]``."""

NEVER_CHANGE = ("workers", "cache_mb", "progress")
"""``ScoreConfig`` fields that never change a number: left out of a pair's key."""

TOP_KEYS = ("output", "settings", "scenes", "methods", "costs")
NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]*$")


@dataclass(frozen=True)
class SuitePair:
    """One ``dynaeval score PRED GT`` of the suite."""

    method: str
    """Method name (leaderboard row; letters, digits, ``._-``)."""
    scene: str
    """Scene name (leaderboard column)."""
    pred: str
    """Folder of the method's predictions of the scene (absolute)."""
    gt: str
    """Folder of the scene's ground truth (absolute)."""

    @property
    def name(self) -> str:
        """``<scene>__<method>``: the stem of its results and key files."""
        return f"{self.scene}__{self.method}"


@dataclass(frozen=True)
class Suite:
    """Every pair of a suite, its settings and its output folder (checked when made)."""

    pairs: tuple[SuitePair, ...]
    """The (method, scene) runs, in the order they are scored."""
    config: ScoreConfig
    """Settings of every run (``method``, ``scene``, ``prepared``, ``progress`` set per run)."""
    out: Path
    """Output folder: ``prepared/``, ``results/``, ``leaderboard.*``, ``index.html``."""
    source: str = ""
    """Where the suite was read from (the TOML file, or ROOT and GT), for messages."""
    costs: dict[str, dict[str, float]] = field(default_factory=dict)
    """Method -> what it costs (``[costs.METHOD]``: ``leaderboard.COSTS`` fields), for the
    leaderboard's cost columns and the page's quality-vs-cost plot."""

    @property
    def scenes(self) -> dict[str, str]:
        """Scene name -> its ground-truth folder, in the order of the pairs."""
        return {p.scene: p.gt for p in self.pairs}

    @property
    def methods(self) -> list[str]:
        """Method names, in the order of the pairs."""
        return list(dict.fromkeys(p.method for p in self.pairs))


@dataclass
class SuiteOutcome:
    """What a run of the suite did."""

    scored: list[str] = field(default_factory=list)
    """Pairs (``<scene>__<method>``) scored by this run."""
    skipped: list[str] = field(default_factory=list)
    """Pairs already scored with the same key (settings and inputs), not scored again."""
    prepared: list[str] = field(default_factory=list)
    """Scenes whose ground truth this run prepared (the others were reused or not needed)."""
    failed: dict[str, str] = field(default_factory=dict)
    """Pair (or ``<scene>`` for a failed prepare) -> the error, one line."""
    repaired: list[str] = field(default_factory=list)
    """What this run found damaged or left over in its own output folder and redid or removed
    (a truncated results file, a prepared file changed since, an interrupted prepare's folder)."""
    results: list[Path] = field(default_factory=list)
    """Results files of every scored pair (this run's and earlier ones), in pair order."""
    leaderboard: list[Path] = field(default_factory=list)
    """The leaderboard files written (md, csv, json)."""
    notes: list[str] = field(default_factory=list)
    """What the suite says besides the pairs' own warnings: a method's run file whose cost
    figures cannot be read (``io.run_costs``)."""
    board: dict[str, Any] | None = None
    """The leaderboard document of every scored pair (``report.leaderboard``), methods ranked;
    None when no pair has results."""
    page: Path | None = None
    """The HTML page written (None when no pair has results)."""


# --------------------------------------------------------------------------------------------
# Reading a suite


def read_toml(path: str | Path) -> dict[str, Any]:
    """The TOML file ``path`` parsed (``tomllib``, Python >= 3.11; else the ``tomli`` package).

    Raises:
        InputError: unreadable file, invalid TOML, nested deeper than the JSON reader's
            ``MAX_DEPTH``, or neither parser there (naming the file).
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as err:
        raise InputError(f"cannot read the file: {err.strerror}", path=path) from None
    except UnicodeDecodeError:
        raise InputError("not a TOML file (not UTF-8 text)", path=path) from None
    try:
        toml = load("tomllib") if sys.version_info >= (3, 11) else load("tomli")
    except MissingDependency:  # Python 3.10 without tomli
        raise InputError("reading SUITE.toml needs Python >= 3.11 or the tomli package: "
                         f"{DEPENDENCIES['tomli'].install} (or use the folder form, dynaeval suite ROOT "
                         "--gt GT -o OUT)", path=path) from None
    if nesting_depth(text) > MAX_DEPTH:  # the parser recurses per level: a RecursionError
        raise InputError(f"nested deeper than {MAX_DEPTH} levels of arrays and tables (a suite "
                         "file needs 3); not a suite file", path=path)
    try:
        return toml.loads(text)
    except toml.TOMLDecodeError as err:
        raise InputError(f"not valid TOML: {err}", path=path) from None
    except RecursionError:
        raise InputError("nested too deeply for the TOML parser; not a suite file",
                         path=path) from None


def settings_config(settings: Any, where: str, base: Path | None = None) -> ScoreConfig:
    """The ``ScoreConfig`` of a suite's ``[settings]`` table (``where``: the file, for
    messages; ``base``: folder that relative ``focus = "boxes:FILE"`` and ``masks`` paths are
    relative to).

    Raises:
        InputError: not a table, a key that is no ``ScoreConfig`` field or one the suite sets
            itself, or a value ``ScoreConfig`` refuses (named ``[settings] KEY``).
    """
    if not isinstance(settings, dict):
        raise InputError("[settings] must be a table of ScoreConfig fields", path=where)
    known = {f.name for f in fields(ScoreConfig)}
    for key in settings:
        if key in FIXED_FIELDS:
            raise InputError(f"[settings] {key}: set by the suite itself (names from [methods] "
                             "and [scenes], its own prepared folders and progress bar); drop it",
                             path=where)
        if key not in known:
            raise InputError(f"[settings] {key}: not a setting; settings are the fields of "
                             f"ScoreConfig: {', '.join(sorted(known - set(FIXED_FIELDS)))}",
                             path=where)
    kw = dict(settings)
    if isinstance(kw.get("metrics"), list):
        kw["metrics"] = tuple(kw["metrics"])
    if base is not None:
        focus = kw.get("focus")
        if isinstance(focus, str) and focus.startswith("boxes:"):
            kw["focus"] = "boxes:" + str(base / focus[len("boxes:"):])
        if isinstance(kw.get("masks"), str):
            kw["masks"] = str(base / kw["masks"])
    try:
        config = ScoreConfig(progress=False, **kw)
        if config.focus.kind.reads_file:  # every task reads it: a bad one is refused here
            read_boxes_file(config.focus.boxes_file)
        return config
    except InputError as err:  # every value is checked there, once (never a TypeError)
        raise InputError(f"[settings]: {err}", path=where) from None


def _name(value: Any, what: str, where: str) -> str:
    if not isinstance(value, str) or not NAME.match(value):
        raise InputError(f"{what} {value!r}: names are letters, digits and . _ - (they name "
                         "the results files)", path=where)
    return value


def _folder(path: Path, what: str, where: str) -> str:
    if not path.is_dir():
        raise InputError(f"{what}: no such folder {path}", path=where)
    return str(path.resolve())


def load_suite(path: str | Path, *, out: str | Path | None = None,
               overwrite: bool = False) -> Suite:
    """Read and check a SUITE.toml (layout: module docstring). ``out`` overrides its
    ``output``.

    Raises:
        InputError: unreadable file or TOML, an unknown top-level key, no scenes or methods, a
            name that cannot name a file, a folder that is not there, ``{scene}`` missing from a
            method's path, bad settings, or an output folder that cannot be written.
    """
    path = Path(path)
    where = str(path)
    doc = read_toml(path)
    base = path.resolve().parent
    for key in doc:
        if key not in TOP_KEYS:
            raise InputError(f"unknown key {key!r}; a suite file has {', '.join(TOP_KEYS)}",
                             path=where)
    config = settings_config(doc.get("settings", {}), where, base)
    scenes = doc.get("scenes")
    if not isinstance(scenes, dict) or not scenes:
        raise InputError("[scenes] is missing or empty: name each scene's ground-truth folder, "
                         "e.g. stadium = \"gt/stadium\"", path=where)
    gts = {_name(s, "[scenes]", where): _folder(base / str(g), f"[scenes] {s}", where)
           for s, g in scenes.items()}
    methods = doc.get("methods")
    if not isinstance(methods, dict) or not methods:
        raise InputError("[methods] is missing or empty: name each method's prediction "
                         "folders, e.g. kplanes = \"runs/kplanes/{scene}\"", path=where)
    pairs = []
    for method, spec in methods.items():
        _name(method, "[methods]", where)
        for scene, pred in _method_folders(method, spec, gts, where).items():
            pairs.append(SuitePair(method, scene, _folder(base / pred, f"[methods] {method} "
                                                          f"(scene {scene})", where), gts[scene]))
    costs = read_costs(doc.get("costs", {}), list(methods), where)
    output = out if out is not None else doc.get("output")
    if not isinstance(output, str | Path) or not str(output):
        raise InputError("no output folder: set output = \"FOLDER\" or pass -o OUT", path=where)
    out_dir = Path(output) if out is not None else base / output
    return _checked(Suite(tuple(pairs), config, out_dir, where, costs), overwrite=overwrite)


def read_costs(table: Any, methods: list[str], where: str) -> dict[str, dict[str, float]]:
    """A ``[costs]`` table (``[costs.METHOD]`` with ``leaderboard.COSTS`` fields, numbers >= 0)
    as method -> costs. Raises InputError naming the key: not a table, a method the suite does
    not score, an unknown field, or a value that is not a number >= 0."""
    if not isinstance(table, dict):
        raise InputError("[costs] must be a table of [costs.METHOD] tables", path=where)
    out = {}
    for method, fields_ in table.items():
        if method not in methods:
            raise InputError(f"[costs] {method}: not a method of the suite "
                             f"({', '.join(methods)})", path=where)
        if not isinstance(fields_, dict):
            raise InputError(f"[costs.{method}] must be a table of {', '.join(COSTS)}",
                             path=where)
        for key, value in fields_.items():
            if key not in COSTS:
                raise InputError(f"[costs.{method}] {key}: not a cost; costs are "
                                 f"{', '.join(COSTS)}", path=where)
            if isinstance(value, bool) or not isinstance(value, int | float) \
                    or not math.isfinite(value) or value < 0:
                raise InputError(f"[costs.{method}] {key} must be a number >= 0, got {value!r}",
                                 path=where)
        out[method] = {k: float(v) for k, v in fields_.items()}
    return out


def _method_folders(method: str, spec: Any, gts: dict[str, str], where: str) -> dict[str, str]:
    """Scene -> prediction folder of one ``[methods]`` entry (a ``{scene}`` template, or a table
    of scene names)."""
    if isinstance(spec, str):
        if "{scene}" not in spec and len(gts) > 1:
            raise InputError(f"[methods] {method} = {spec!r} has no {{scene}}: with several "
                             "scenes, write its folders as \"runs/NAME/{scene}\" or as a table "
                             "{scene = \"folder\"}", path=where)
        return {s: spec.replace("{scene}", s) for s in gts}
    if isinstance(spec, dict) and spec:
        for scene, pred in spec.items():
            if scene not in gts:
                raise InputError(f"[methods] {method}: scene {scene!r} is not in [scenes] "
                                 f"({', '.join(gts)})", path=where)
            if not isinstance(pred, str):
                raise InputError(f"[methods] {method}.{scene} must be a folder path", path=where)
        return dict(spec)
    raise InputError(f"[methods] {method} must be a folder path with {{scene}} or a table "
                     "of scene = folder", path=where)


def folder_suite(root: str | Path, gt: str | Path, out: str | Path,
                 config: ScoreConfig | None = None, *, overwrite: bool = False,
                 costs: Any = None) -> Suite:
    """The suite of the folder convention: ``ROOT/<method>/<scene>`` scored against
    ``GT/<scene>`` (hidden folders and the output folder are no method).

    Raises:
        InputError: ROOT or GT not a folder, a ``ROOT/<method>/<scene>`` without
            ``GT/<scene>``, a name that cannot name a file, no pair, bad output folder.
    """
    root, gt, out = Path(root), Path(gt), Path(out)
    where = f"{root} --gt {gt}"
    for folder, what in ((root, "ROOT"), (gt, "GT")):
        if not folder.is_dir():
            raise InputError(f"{what} is not a folder", path=folder)
    skip = {out.resolve(), gt.resolve()}
    pairs = []
    for mdir in sorted(p for p in root.iterdir() if p.is_dir() and not p.name.startswith(".")
                       and p.resolve() not in skip):
        method = _name(mdir.name, "method folder", str(mdir))
        for sdir in sorted(p for p in mdir.iterdir() if p.is_dir() and not p.name.startswith(".")):
            scene = _name(sdir.name, "scene folder", str(sdir))
            if not (gt / scene).is_dir():
                raise InputError(f"no ground truth for scene {scene!r}: {gt / scene} is not a "
                                 "folder (ROOT/<method>/<scene> is scored against GT/<scene>)",
                                 path=sdir)
            pairs.append(SuitePair(method, scene, str(sdir.resolve()), str((gt / scene).resolve())))
    if not pairs:
        raise InputError("no ROOT/<method>/<scene> folder: the folder form expects one "
                         "folder per method holding one folder per scene", path=root)
    config = replace(config or ScoreConfig(), progress=False)
    methods = list(dict.fromkeys(p.method for p in pairs))
    return _checked(Suite(tuple(pairs), config, out, where, read_costs(costs or {}, methods, where)),
                    overwrite=overwrite, roots=(root,))


MARKER = ".dynaeval-suite"
"""The file a suite writes into its output folder: the folder is the suite's own (its
``results/``, ``prepared/``, leaderboards and page may be replaced and repaired)."""


def _checked(suite: Suite, *, overwrite: bool = False, roots: tuple[Path, ...] = ()) -> Suite:
    """``suite`` once its output folder can be written, no scene has two GT folders, no two
    pairs write one results file, and the output folder is the suite's own (or empty, or
    ``overwrite``) and inside none of its inputs (nor equal to a folder form's ``roots``).
    Raises InputError naming the suite (or the folder) and the problem."""
    seen: dict[str, str] = {}
    names: dict[str, SuitePair] = {}
    for p in suite.pairs:
        if seen.setdefault(p.scene, p.gt) != p.gt:
            raise InputError(f"scene {p.scene!r} has two ground-truth folders", path=suite.source)
        other = names.setdefault(p.name, p)
        if other is not p:
            raise InputError(f"scene {other.scene!r} with method {other.method!r} and scene "
                             f"{p.scene!r} with method {p.method!r} would both write "
                             f"results/{p.name}.json; rename one ('__' joins scene and method)",
                             path=suite.source)
    if not suite.pairs:
        raise InputError("the suite has no (method, scene) pair", path=suite.source)
    inputs = [*{p.pred for p in suite.pairs}, *seen.values()]
    check_writable(suite.out, overwrite=True, what="suite output folder", inputs=inputs,
                   folder=True)
    out = suite.out.resolve()
    for folder in [*inputs, *roots]:
        inside = Path(folder).resolve()
        if out == inside or (folder in inputs and inside in out.parents):
            raise InputError(f"the suite output folder is inside an input of the suite ({folder}): "
                             "its own files would be read as frames or methods and hashed into "
                             "every rerun's keys; choose a folder outside", path=suite.out)
    if not overwrite and not _own_or_empty(suite.out):
        raise InputError("the suite output folder holds files that are not a suite's output (no "
                         f"{MARKER}): pass --overwrite to let the suite write its results, "
                         "leaderboards and index.html there, or choose an empty or new folder",
                         path=suite.out)
    return suite


def _own_or_empty(out: Path) -> bool:
    """Whether ``out`` is missing, empty, or a suite's output (its marker, or the ``results/
    *.key`` files every suite wrote before the marker existed)."""
    if not out.is_dir() or not any(p.name != LOCK_NAME for p in out.iterdir()):
        return True  # a lock file alone: another run's, refused when it is taken
    return (out / MARKER).is_file() or any((out / "results").glob("*.key"))


# --------------------------------------------------------------------------------------------
# Keys: what a result depends on


def _jsonable(value: Any) -> Any:
    return json.loads(json.dumps(value, default=str, sort_keys=True))


def config_key(config: ScoreConfig) -> dict[str, Any]:
    """The settings of ``config`` that can change a number, with the digest of a boxes file or
    detector model it names (a JSON-compatible dict)."""
    settings = {k: v for k, v in asdict(config).items() if k not in NEVER_CHANGE + FIXED_FIELDS}
    files = [f for f in (config.focus.boxes_file, config.focus.detector_model, config.masks) if f]
    settings["files"] = {str(f): (file_digest(f) if Path(f).is_file() else
                                  folder_digests(f) if Path(f).is_dir() else None) for f in files}
    return _jsonable(settings)


def pair_key(pair: SuitePair, settings: dict[str, Any], gt_digests: dict[str, str]) -> str:
    """The key of one pair's results: version, settings (``config_key``), names and the digest
    of every prediction and ground-truth file."""
    return json_digest({"dynaeval": VERSION, "settings": settings, "method": pair.method,
                        "scene": pair.scene, "pred": folder_digests(pair.pred), "gt": gt_digests},
                       16)


def prepare_key(settings: dict[str, Any], gt_digests: dict[str, str]) -> str:
    """The key of a scene's prepared folder (dynaeval and prepared-format versions, settings,
    ground-truth files): a folder of an older format is prepared again, not refused."""
    return json_digest({"dynaeval": VERSION, "format": FORMAT_VERSION, "settings": settings,
                        "gt": gt_digests}, 16)


def _read_key(path: Path) -> str | None:
    try:
        return path.read_text(encoding="utf-8").strip()
    except OSError:
        return None


# --------------------------------------------------------------------------------------------
# Tasks (run on a worker: paths in, small dicts out)


def prepare_task(gt: str, out: str, config: ScoreConfig) -> str:
    """Prepare ``gt`` into ``out`` (replacing it); returns the prepared folder's id."""
    return prepare(gt, out, config, overwrite=True, progress=False)["id"]


def score_task(pair: SuitePair, prepared: str, config: ScoreConfig) -> dict[str, Any]:
    """Score one pair against its prepared ground truth; the results as a dict (its warnings
    are in it, not issued)."""
    job = ScoreJob(pair.pred, pair.gt, method=pair.method, scene=pair.scene,
                   overrides={"prepared": prepared})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DynaevalWarning)
        return score_shard(job, 1, 1, {f.name: getattr(config, f.name)
                                       for f in fields(ScoreConfig)})


class InlineExecutor:
    """``submit`` runs the call at once, in this thread (the local suite): a done future."""

    def submit(self, fn: Callable[..., Any], *args: Any) -> concurrent.futures.Future:
        future: concurrent.futures.Future = concurrent.futures.Future()
        try:
            future.set_result(fn(*args))
        except Exception as err:  # noqa: BLE001 - handed to the caller through the future
            future.set_exception(err)
        return future


Call = tuple[Any, ...]
"""A task: ``(tag, fn, *args)``; ``tag`` tells the handler what it was."""


def _run_calls(executor: Any, calls: list[Call],
               handle: Callable[[Any, Any], list[Call]]) -> None:
    """Run ``calls`` on ``executor``; ``handle(tag, future)`` as each one is done, which returns
    the calls that may start now (a scene's pairs once its ground truth is prepared).

    On the ``InlineExecutor`` the calls run in order, one after the other (a result is written
    before the next call starts; follow-ups after the calls already queued); elsewhere every
    call is submitted as soon as it may start and handled as it finishes (Dask's own
    ``as_completed`` for a Dask client, ``concurrent.futures.wait`` for an executor of that
    module), so on a cluster a scene's pairs do not wait for the other scenes' prepares.
    """
    if isinstance(executor, InlineExecutor):
        queue = collections.deque(calls)
        while queue:
            tag, *call = queue.popleft()
            queue.extend(handle(tag, executor.submit(*call)))
        return
    tags: dict[Any, Any] = {}

    def submit(batch: list[Call]) -> list[Any]:
        futures = [executor.submit(*call) for _, *call in batch]
        tags.update(zip(futures, (tag for tag, *_ in batch), strict=True))
        return futures

    if type(executor).__module__.split(".")[0] == "distributed":
        stop = threading.Event()
        threading.Thread(target=_watch_workers, args=(executor, stop), daemon=True,
                         name="dynaeval-dask-workers").start()
        try:
            done = load("distributed").as_completed(submit(calls))
            for future in done:
                for follow in submit(handle(tags.pop(future), future)):
                    done.add(follow)
        finally:
            stop.set()
        return
    pending = set(submit(calls))
    while pending:
        finished, pending = concurrent.futures.wait(
            pending, return_when=concurrent.futures.FIRST_COMPLETED)
        for future in finished:
            pending.update(submit(handle(tags.pop(future), future)))


NO_WORKER_EVERY = 30.0
"""Seconds between the checks that the Dask scheduler still has a worker, and between the
warnings while it has none (a client whose only worker died waited without a word)."""


def _watch_workers(client: Any, stop: threading.Event) -> None:
    """While the suite runs on ``client``: every ``NO_WORKER_EVERY`` seconds, say on stderr when
    the scheduler has no worker. The suite keeps waiting (a worker that starts picks the tasks
    up); Ctrl-C stops it and keeps what was scored."""
    while not stop.wait(NO_WORKER_EVERY):
        try:
            workers = client.scheduler_info()["workers"]
        except Exception:  # noqa: BLE001 - the scheduler gone: the client's own error ends the run
            return
        if not workers and not stop.is_set():
            print("dynaeval: warning: the Dask scheduler has no worker: the suite waits for one "
                  "(start a worker on it, or Ctrl-C: the pairs scored so far are kept)",
                  file=sys.stderr, flush=True)


def _error_line(err: BaseException) -> str:
    text = str(err).strip().splitlines()
    return f"{type(err).__name__}: {text[0] if text else ''}".rstrip(": ")


# --------------------------------------------------------------------------------------------
# Running


def run_suite(suite: Suite, executor: Any = None, *, progress: bool = True,
              on_result: Callable[[str], None] | None = None,
              sort: str | None = None) -> SuiteOutcome:
    """Prepare, score what is missing, write the leaderboard and the page (module docstring).

    Args:
        suite: from ``load_suite`` or ``folder_suite``.
        executor: None (this process, one task at a time), a Dask ``distributed.Client`` or a
            ``concurrent.futures`` executor.
        progress: one bar over the whole suite on stderr (ground-truth frames prepared, frames
            scored).
        on_result: called with the pair's name after each results file is written.
        sort: the metric that ranks each scene's methods in the leaderboard (``dynaeval
            leaderboard --sort``; default the first whole-frame metric), checked before any
            work (``check_sort``).

    Returns:
        What was scored, skipped, prepared and what failed (with the error).

    Raises:
        InputError: another run is writing into ``suite.out`` (``dynaeval.io.lock``); ``sort``
            is not a metric the suite computes.
    """
    check_sort(suite.config, sort)
    (suite.out / "results").mkdir(parents=True, exist_ok=True)
    (suite.out / "prepared").mkdir(exist_ok=True)
    if not (suite.out / MARKER).is_file():
        write_text_atomic(suite.out / MARKER, "This folder is the output of `dynaeval suite`; "
                          "a suite run into it replaces and repairs its files.\n",
                          overwrite=True, what="suite marker file")
    with hold_folder(suite.out, "suite output folder"):
        return _run_held(suite, executor or InlineExecutor(), progress, on_result, sort)


def check_sort(config: ScoreConfig, sort: str | None) -> None:
    """Refuse, before any work, a ``sort`` metric that is not a result key of the registry or
    that ``config`` does not compute (a per-frame metric not in ``metrics``, a temporal term
    with ``temporal`` off, an object metric with ``presence`` off). A region the run cannot
    fill (``focused_*`` without boxes) is refused when the leaderboard is built.

    Raises:
        InputError: naming the metric and why (did-you-mean for an unknown name).
    """
    if sort is None:
        return
    if sort not in METRICS:
        raise InputError(f"cannot sort by {sort!r}: not a metric{did_you_mean(sort, METRICS)}")
    info = METRICS[sort]
    if SPECS[info.metric].build is not None and info.metric not in config.metrics:
        off = f"{info.metric!r} is not among the settings' metrics"
    elif info.kind in ("pair", "camera") and SPECS[info.metric].build is None \
            and not config.temporal:
        off = "the temporal terms are off (temporal = false)"
    elif info.kind == "object" and not config.presence:
        off = "presence is off (presence = false)"
    else:
        return
    raise InputError(f"cannot sort by {sort!r}: the suite does not compute it: {off}")


def _run_held(suite: Suite, executor: Any, progress: bool,
              on_result: Callable[[str], None] | None, sort: str | None) -> SuiteOutcome:
    """``run_suite``'s work, while this process holds ``suite.out``."""
    out = suite.out
    outcome = SuiteOutcome()
    outcome.repaired += _remove_leftovers(out)
    settings = config_key(suite.config)
    gt_digests = {s: folder_digests(g) for s, g in suite.scenes.items()}
    keys = {p.name: pair_key(p, settings, gt_digests[p.scene]) for p in suite.pairs}
    for p in suite.pairs:
        damage = _result_damage(out, p, keys[p.name])
        if damage:
            outcome.repaired.append(f"results/{p.name}.json {damage}: scored again")
            (out / "results" / f"{p.name}.key").unlink(missing_ok=True)
    todo = [p for p in suite.pairs if not _done(out, p, keys[p.name])]
    outcome.skipped = [p.name for p in suite.pairs if p not in todo]
    scenes = {p.scene: p.gt for p in todo}
    prep_keys = {s: prepare_key(settings, gt_digests[s]) for s in scenes}
    to_prepare = {}
    for s, g in scenes.items():
        if _read_key(out / "prepared" / f"{s}.key") != prep_keys[s]:
            to_prepare[s] = g
        elif (damage := _prepared_damage(out / "prepared" / s)) is not None:
            outcome.repaired.append(f"prepared/{s} {damage}: prepared again")
            to_prepare[s] = g
    bar = Progress({"regions": sum(len(gt_digests[s]) for s in to_prepare),
                    "frames": sum(len(gt_digests[p.scene]) for p in todo)},
                   enabled=progress and bool(todo), desc="suite")
    tasks = _Tasks(suite, keys, prep_keys, gt_digests, bar, outcome, on_result,
                   {s: [p for p in todo if p.scene == s] for s in to_prepare})
    completed = False
    try:
        _run_calls(executor, [*(tasks.prepare_call(s) for s in to_prepare),
                              *(tasks.score_call(p) for p in todo if p.scene not in to_prepare)],
                   tasks.handle)
        completed = True
    finally:
        bar.close(completed)
    order = {name: i for i, name in enumerate([*suite.scenes, *(p.name for p in suite.pairs)])}
    outcome.scored.sort(key=order.__getitem__)  # in the suite's order, not as they finished
    outcome.prepared.sort(key=order.__getitem__)
    outcome.failed = dict(sorted(outcome.failed.items(), key=lambda kv: order[kv[0]]))
    outcome.results = [out / "results" / f"{p.name}.json" for p in suite.pairs
                       if _done(out, p, keys[p.name])]
    _write_summaries(suite, outcome, sort)
    return outcome


def _remove_leftovers(out: Path) -> list[str]:
    """Remove the folders an interrupted prepare left in ``out/prepared`` (``.<scene>.*.tmp``;
    no other run writes there while this one holds ``out``); what was removed."""
    import shutil

    gone = []
    for tmp in sorted((out / "prepared").glob(".*.tmp")):
        if tmp.is_dir():
            shutil.rmtree(tmp, ignore_errors=True)
            gone.append(f"prepared/{tmp.name} (left by an interrupted prepare) removed")
    return gone


def _result_damage(out: Path, pair: SuitePair, key: str) -> str | None:
    """Why the pair's results file, whose key file says it is done, cannot be read (truncated,
    edited, damaged), or None (fine, or not done: nothing to repair)."""
    if not _done(out, pair, key):
        return None
    try:
        load_results(out / "results" / f"{pair.name}.json")
    except InputError as err:
        return f"is damaged ({str(err).split(': ', 1)[-1]})"
    return None


def _prepared_damage(folder: Path) -> str | None:
    """Why the suite's prepared folder cannot be used as it is (no or a damaged manifest, a file
    missing or changed since it was written), or None."""
    try:
        manifest = read_manifest(folder)
    except InputError as err:
        return f"is damaged ({str(err).split(': ', 1)[-1]})"
    for rel, digest in manifest.get("hashes", {}).items():
        path = folder / rel
        if not path.is_file() or file_digest(path) != digest:
            return f"is damaged ({rel} missing or changed since it was written)"
    return None


def _done(out: Path, pair: SuitePair, key: str) -> bool:
    return ((out / "results" / f"{pair.name}.json").is_file()
            and _read_key(out / "results" / f"{pair.name}.key") == key)


@dataclass
class _Tasks:
    """A suite's prepare and score calls, and what is done as each finishes: key files and
    results written here (by the client), failures recorded, a prepared scene's pairs released.
    State is real here: the outcome and the pairs waiting for their ground truth."""

    suite: Suite
    keys: dict[str, str]
    prep_keys: dict[str, str]
    gt_digests: dict[str, dict[str, str]]
    bar: Progress
    outcome: SuiteOutcome
    on_result: Callable[[str], None] | None
    waiting: dict[str, list[SuitePair]]
    """Scene -> its pairs, held until the scene's ground truth is prepared."""

    def prepare_call(self, scene: str) -> Call:
        return (("prepare", scene), prepare_task, self.suite.scenes[scene],
                str(self.suite.out / "prepared" / scene), self.suite.config)

    def score_call(self, pair: SuitePair) -> Call:
        return (("score", pair), score_task, pair, str(self.suite.out / "prepared" / pair.scene),
                self.suite.config)

    def handle(self, tag: tuple[str, Any], future: Any) -> list[Call]:
        kind, what = tag
        if kind == "prepare":
            return self._prepared(what, future)
        self._scored(what, future)
        return []

    def _prepared(self, scene: str, future: Any) -> list[Call]:
        pairs = self.waiting.pop(scene)
        try:
            future.result()
        except Exception as err:  # noqa: BLE001 - reported, the other scenes go on
            self.outcome.failed[scene] = _error_line(err)
            for p in pairs:
                self.outcome.failed[p.name] = f"ground truth not prepared: {self.outcome.failed[scene]}"
            pairs = []
        else:
            write_text_atomic(self.suite.out / "prepared" / f"{scene}.key",
                              self.prep_keys[scene] + "\n", overwrite=True, what="suite key file")
            self.outcome.prepared.append(scene)
        self.bar.advance("regions", len(self.gt_digests[scene]), note=f"prepared {scene}")
        return [self.score_call(p) for p in pairs]

    def _scored(self, pair: SuitePair, future: Any) -> None:
        """Each results file, then its key file, written as the pair's task finishes."""
        try:
            doc = future.result()
        except Exception as err:  # noqa: BLE001 - reported, the other pairs go on
            self.outcome.failed[pair.name] = _error_line(err)
        else:
            base = self.suite.out / "results" / pair.name
            write_text_atomic(base.with_suffix(".json"), results_text(doc), overwrite=True,
                              what="results file")
            write_text_atomic(base.with_suffix(".key"), self.keys[pair.name] + "\n",
                              overwrite=True, what="suite key file")
            self.outcome.scored.append(pair.name)
            if self.on_result is not None:
                self.on_result(pair.name)
        self.bar.advance("frames", len(self.gt_digests[pair.scene]), note=pair.name)


def _write_summaries(suite: Suite, outcome: SuiteOutcome, sort: str | None) -> None:
    """The leaderboard (md, csv, json; ranked by ``sort``) and the page of every pair with
    results."""
    if not outcome.results:
        return
    scored = {(p.method, p.scene): p for p in suite.pairs
              if suite.out / "results" / f"{p.name}.json" in outcome.results}
    run_costs = {key: read_run_costs(p.pred) for key, p in scored.items()}
    outcome.notes += [rc.note for rc in run_costs.values() if rc.note]
    board = build_leaderboard(outcome.results, costs=suite.costs, run_costs=run_costs,
                              sort=sort)
    outcome.board = board
    for fmt in ("md", "csv", "json"):
        path = suite.out / f"leaderboard.{fmt}"
        write_text_atomic(path, render(board, fmt), overwrite=True, what="leaderboard file")
        outcome.leaderboard.append(path)
    docs = [load_results(p) for p in outcome.results]
    page = suite.out / "index.html"
    write_text_atomic(page, render_suite_page(docs, board), overwrite=True, what="suite page")
    outcome.page = page


def summary_lines(outcome: SuiteOutcome) -> list[str]:
    """The end-of-run summary: counts, then one line per failure."""
    lines = [f"{len(outcome.scored)} pair(s) scored, {len(outcome.skipped)} already scored "
             f"(skipped), {len(outcome.failed)} failed; {len(outcome.prepared)} scene(s) prepared"]
    lines += [f"failed: {name}: {err}" for name, err in outcome.failed.items()]
    lines += [f"repaired: {what}" for what in outcome.repaired]
    if outcome.leaderboard:
        lines.append(f"leaderboard: {', '.join(map(str, outcome.leaderboard))}")
    if outcome.page is not None:
        lines.append(f"page: {outcome.page}")
    return lines

