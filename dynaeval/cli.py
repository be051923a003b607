"""Command line: a thin layer of argument parsing over the library.

Exit codes: 0 scored; 2 bad input or usage (the message names the file and what is wrong);
1 a bug (a traceback is printed: please report it).
"""

from __future__ import annotations

import argparse
import sys
import traceback
from pathlib import Path
from typing import Any

from dynaeval import __version__
from dynaeval.config import BACKGROUNDS, DEVICES, QUANTIZE_MODES, ScoreConfig
from dynaeval.errors import InputError
from dynaeval.evaluate import DynaevalWarning, score, warning_text
from dynaeval.io.atomic import check_writable, write_files_atomic, write_text_atomic
from dynaeval.io.frames import parse_shard
from dynaeval.metrics.flow import FLOW_METHODS
from dynaeval.metrics.perceptual import LPIPS_BACKENDS, LPIPS_NETS
from dynaeval.metrics.protocols import PROTOCOL_NAMES
from dynaeval.metrics.registry import SPECS, selectable_specs
from dynaeval.prepare import prepare
from dynaeval.regions import fetch, write_boxes_file
from dynaeval.regions.fetch import CACHE_ENV, KNOWN
from dynaeval.regions.focus import FocusConfig, detect_ground_truth
from dynaeval.regions.summary import describe_regions
from dynaeval.report import summary_table, write_json_atomic
from dynaeval.report.gaussian_splatting import gs_files, gs_paths
from dynaeval.report.html import RegionRecorder, render_report, report_index
from dynaeval.report.leaderboard import build_leaderboard, forced_fields, render
from dynaeval.report.merge import merge_results
from dynaeval.report.results import results_text
from dynaeval.runtime import check_opencv, keep_freed_memory
from dynaeval.suite_cli import add_suite_command, run_suite_command

EXIT_OK, EXIT_BUG, EXIT_INPUT = 0, 1, 2

FOLDERS_RULE = "missing folders are created when it is written"
"""The one rule of every output option (``dynaeval.io.atomic.parent_folders``), in its help."""


def sample_dir() -> Path:
    """Folder of the sample scene shipped inside the package (``pred/`` and ``gt/``)."""
    return Path(__file__).resolve().parent / "data" / "sample"


_DEFAULTS = None


def _defaults() -> Any:
    """``ScoreConfig()``: the CLI's defaults are the library's."""
    global _DEFAULTS
    if _DEFAULTS is None:
        _DEFAULTS = ScoreConfig()
    return _DEFAULTS


def _add_metric_flags(p: argparse.ArgumentParser) -> None:
    """``--metrics NAME ...`` (exactly these), ``--no-NAME`` for every chosen metric (per-frame
    or video) that runs by default, ``--NAME`` for the others (from the registry)."""
    names = [s.name for s in selectable_specs()]
    p.add_argument("--metrics", nargs="+", choices=names, metavar="NAME",
                   help=f"compute exactly these metrics ({', '.join(names)}), instead of "
                        "the defaults adjusted by --no-NAME / --NAME (which it cannot be combined "
                        "with)")
    options = [f"{s.name}.{o}" for s in selectable_specs() for o, _, _ in s.options]
    p.add_argument("--metric-option", action="append", default=[], metavar="NAME.OPTION=VALUE",
                   dest="metric_option",
                   help=f"an option of one metric (repeatable): {', '.join(options) or 'none'}")
    for spec in selectable_specs():
        extra = f" (needs pip install 'dynaeval[{spec.extra}]')" if spec.extra else ""
        flag, dest = _metric_flag(spec)
        what = f"skip {spec.title}" if spec.default else f"also compute {spec.title}: {spec.description}"
        p.add_argument(flag, action="store_true", dest=dest, help=what + extra)
    p.add_argument("--flip-every", type=int, metavar="K",
                   help="FLIP on every K-th frame only (frame index %% K == 0; K-Planes uses 10; "
                        "= --metric-option flip.every=K)")
    p.add_argument("--fps", type=float, default=_defaults().fps, metavar="FPS",
                   help="frame rate of cameras given as image files, for JOD (default: "
                        f"{_defaults().fps:g}; a video file's own rate is used)")


def _metric_flag(spec: Any) -> tuple[str, str]:
    """The flag that toggles a per-frame metric and its argparse dest: ``--no-NAME`` for one on
    by default, ``--NAME`` for one off by default."""
    return spec.flag, f"no_{spec.name}" if spec.default else f"with_{spec.name}"


def _add_classes_flag(p: argparse.ArgumentParser) -> None:
    p.add_argument("--classes", nargs="+", metavar="CLASS",
                   help="the detector's classes to keep, by name or integer id, separated by "
                        "commas or spaces (a name with a space, e.g. 'sports ball', needs commas "
                        "or quotes); default: person, sports ball")


def parse_classes(items: list[str] | None) -> tuple[str | int, ...] | None:
    """``--classes`` values -> class names and ids: each item split at commas, stripped,
    digits as integer ids (``["person,32", "sports ball"]`` -> ``("person", 32, "sports ball")``).

    Raises:
        InputError: no class left (``--classes ,``).
    """
    if items is None:
        return None
    parts = [p.strip() for item in items for p in item.split(",")]
    out = tuple(int(p) if p.isdigit() else p for p in parts if p)
    if not out:
        raise InputError("--classes names no class: give names or ids, e.g. --classes person,ball")
    return out


def _add_score_options(p: argparse.ArgumentParser) -> None:
    d = _defaults()
    p.add_argument("--method", help="method name for the leaderboard (default: PRED's folder name)")
    p.add_argument("--scene", help="scene name for the leaderboard (default: GT's folder name)")
    _add_metric_flags(p)
    p.add_argument("--lpips-net", choices=LPIPS_NETS, default=d.lpips_net,
                   help="LPIPS backbone (default: alex, or the protocol's: vgg for 3dgs and "
                        "4dgaussians, which also allows alex)")
    p.add_argument("--lpips-backend", choices=LPIPS_BACKENDS, default=d.lpips_backend,
                   help="run the LPIPS network with torch (the lpips package, default) or the same "
                        "network exported to onnxruntime (faster on CPU, equal to 1e-6)")
    p.add_argument("--quantize", choices=QUANTIZE_MODES, default=d.quantize,
                   help="quantise both images to 8 bit before scoring, as some evaluators do "
                        "(default: none, or the protocol's)")
    p.add_argument("--protocol", choices=PROTOCOL_NAMES, default=d.protocol,
                   help="reproduce another evaluator's whole-frame PSNR/SSIM and 8-bit step "
                        "(docs/protocols.md; default: dynaeval)")
    p.add_argument("--iteration", type=int, metavar="N",
                   help="3DGS-family MODEL folder: score ours_N (default: the latest rendered)")
    p.add_argument("--split", metavar="NAME",
                   help="3DGS-family MODEL folder: score this split (default: test)")
    p.add_argument("--background", choices=BACKGROUNDS, default=d.background,
                   help=f"colour RGBA frames are composited over (default: {d.background})")
    p.add_argument("--allow-missing", action="store_true",
                   help="score the frames present when a camera misses some predictions, and "
                        "record what was skipped")
    p.add_argument("--focus", default=d.focus.source, metavar="detector|motion|boxes:FILE|none",
                   help="boxes for the focused_* metrics, from the ground truth: the ONNX detector "
                        "(default), connected components of the motion masks, a boxes file "
                        "(dynaeval detect, or the scene generator's boxes.json), or none")
    p.add_argument("--detector", metavar="MODEL.onnx|NAME",
                   help="ONNX detector for --focus detector, or the name of one fetched with "
                        "'dynaeval detector fetch' (default: the one shipped with dynaeval, for "
                        "the synthetic scenes)")
    _add_classes_flag(p)
    p.add_argument("--expand", choices=["paper", "margin", "none"], default=d.focus.expand,
                   help="box expansion: paper = width x7, height x2.5 as in the seed study "
                        "(default), margin, or none; boxes are then clipped and merged")
    p.add_argument("--no-masked", action="store_true",
                   help="skip motion masks and the masked_* metrics")
    p.add_argument("--masks", metavar="DIR",
                   help="given masks, one grey PNG per ground-truth frame at the same relative "
                        "path (or a DyCheck dataset folder: its covisible/<factor>x/<split>/): "
                        "masked_* are computed over them instead of the motion masks, and the "
                        "protocol uses them as its source does (default: a NeRFBaselines "
                        "render folder's mask/, DyCheck's covisible/ beside rgb/<factor>x/)")
    p.add_argument("--no-presence", action="store_true",
                   help="skip the per-object presence check (presence_person, presence_ball, "
                        "tight_psnr_*)")
    p.add_argument("--no-temporal", action="store_true",
                   help="skip the temporal metrics (warp_error, tof, tlp, flicker)")
    p.add_argument("--frames-are-video", action="store_true",
                   help="score a render folder's frames (NeRFBaselines, ns-render, "
                        "gaussian-splatting: separate test views, scored per frame only by "
                        "default) as one video per camera: temporal terms and motion masks")
    p.add_argument("--flow", choices=FLOW_METHODS, default=d.flow,
                   help=f"optical flow for the temporal metrics (default: {d.flow})")
    p.add_argument("--workers", type=int, default=d.workers, metavar="N",
                   help=f"threads scoring frames and pairs, and cameras scored at a time; never "
                   f"changes a number (default: {d.workers})")
    p.add_argument("--device", choices=DEVICES, default=d.device,
                   help=f"torch device for LPIPS and the detector (default: {d.device})")
    p.add_argument("--cache-mb", type=int, default=d.cache_mb, metavar="MB",
                   help=f"decoded frames kept per camera so each file is decoded once (default: "
                        f"{d.cache_mb}; a 1080p frame is 25 MB, and a camera needs its ground "
                        "truth and predictions); never changes a number")
    p.add_argument("-o", "--output", metavar="results.json",
                   help=f"write the results JSON here (atomically; {FOLDERS_RULE})")
    p.add_argument("--overwrite", action="store_true", help="replace an existing -o file")
    p.add_argument("--3dgs-json", dest="gs_json", metavar="DIR",
                   help="also write DIR/results.json and DIR/per_view.json in the shape of the "
                        "3DGS family's metrics.py (their numbers with --protocol 3dgs, or "
                        f"4dgaussians; {FOLDERS_RULE})")
    p.add_argument("--report", metavar="DIR",
                   help="also write an HTML report, DIR/index.html (one file, its images inlined): "
                        "summary, per-frame curves, worst frames with the scored regions drawn "
                        f"({FOLDERS_RULE})")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.add_argument("--prepared", metavar="PREP",
                   help="a ground truth prepared with 'dynaeval prepare GT -o PREP': its regions "
                        "and flows are read, not computed (refused if GT or a setting changed); "
                        "never changes a number")
    p.add_argument("--shard", metavar="I/N",
                   help="score only the I-th of N slices of the cameras (1 <= I <= N); "
                        "'dynaeval merge' combines the N results into the unsharded numbers")


def _metrics_from_args(args: argparse.Namespace) -> tuple[str, ...]:
    """The per-frame metrics asked for: ``--metrics`` exactly (in registry order), else the
    registry's defaults minus ``--no-NAME`` plus ``--NAME``.

    Raises:
        InputError: ``--metrics`` given together with a ``--no-NAME`` / ``--NAME`` flag.
    """
    specs = selectable_specs()
    toggled = [s for s in specs if getattr(args, _metric_flag(s)[1], False)]
    chosen = getattr(args, "metrics", None)
    if chosen:
        flags = [_metric_flag(s)[0] for s in toggled]
        if flags:
            raise InputError(f"--metrics sets the metrics exactly and cannot be combined with "
                             f"{', '.join(flags)}: drop {'it' if len(flags) == 1 else 'them'} "
                             "or --metrics")
        return tuple(s.name for s in specs if s.name in chosen)
    return tuple(s.name for s in specs if s.default != (s in toggled))


def config_from_args(args: argparse.Namespace) -> Any:
    """The ``ScoreConfig`` of parsed ``score``/``demo`` arguments (options a command lacks keep
    the library's defaults).

    Raises:
        InputError: conflicting options (``--metrics`` with ``--no-NAME``; ``--detector``
            without ``--focus detector``), a value ``ScoreConfig`` refuses, or a metric named
            (``--flip``, ``--metrics lpips``, ``--lpips-net``) that cannot run here.
    """
    from dataclasses import replace

    d = _defaults()
    metrics = _metrics_from_args(args)
    if getattr(args, "detector", None) and getattr(args, "focus", d.focus.source) != "detector":
        raise InputError(f"--detector is only used with --focus detector (got --focus "
                         f"{args.focus}): drop --detector, or pass --focus detector")
    opt = lambda name: getattr(args, name, getattr(d, name))  # noqa: E731
    config = replace(
        d, method=getattr(args, "method", None), scene=getattr(args, "scene", None),
        metrics=metrics, metric_options=_metric_options(getattr(args, "metric_option", []),
                                                        getattr(args, "flip_every", None), metrics),
        fps=opt("fps"),
        lpips_net=opt("lpips_net"), lpips_backend=opt("lpips_backend"),
        quantize=opt("quantize"), background=opt("background"),
        allow_missing=opt("allow_missing"), workers=opt("workers"), cache_mb=opt("cache_mb"),
        device=opt("device"), progress=not args.quiet,
        shard=parse_shard(args.shard) if getattr(args, "shard", None) else None,
        focus=FocusConfig.parse(args.focus, detector_model=getattr(args, "detector", None),
                                classes=parse_classes(getattr(args, "classes", None)),
                                expand=getattr(args, "expand", d.focus.expand),
                                masked=not getattr(args, "no_masked", False),
                                device=opt("device")),
        temporal=not getattr(args, "no_temporal", False),
        presence=not getattr(args, "no_presence", False),
        flow=opt("flow"), protocol=opt("protocol"), masks=opt("masks"),
        iteration=getattr(args, "iteration", None), split=getattr(args, "split", None),
        prepared=getattr(args, "prepared", None),
        frames_are_video=True if getattr(args, "frames_are_video", False) else None,
    )
    named = [*(getattr(args, "metrics", None) or ()),
             *(("lpips",) if getattr(args, "lpips_net", None) else ())]
    config.require_metrics(named)  # asked for by name: refused now if it cannot run
    return config


def _metric_options(specs: list[str], flip_every: int | None = None,
                    metrics: tuple[str, ...] = ()) -> dict[str, dict[str, Any]]:
    """``["flip.pixels_per_degree=40"]`` -> ``{"flip": {"pixels_per_degree": "40"}}`` (the
    config converts and checks the values); ``--flip-every K`` is ``flip.every=K``.

    Raises:
        InputError: a malformed option, or an option of a registered metric that is not
            computed (``--flip-every`` without ``--flip``, ``--metric-option jod.model=fvvdp``
            without ``--jod``), naming both flags.
    """
    out: dict[str, dict[str, Any]] = {}
    given: list[tuple[str, str]] = []  # (metric, the flag as typed)
    if flip_every is not None:
        out["flip"] = {"every": flip_every}
        given.append(("flip", "--flip-every"))
    for spec in specs:
        key, sep, value = spec.partition("=")
        metric, dot, name = key.partition(".")
        if not (sep and dot and metric and name and value):
            raise InputError(f"--metric-option must be NAME.OPTION=VALUE, e.g. "
                             f"flip.pixels_per_degree=40; got {spec!r}")
        out.setdefault(metric, {})[name] = value
        given.append((metric, f"--metric-option {spec}"))
    for metric, flag in given:  # an unknown metric is the config's error (it lists them)
        if metric in SPECS and metric not in metrics:
            s = SPECS[metric]
            raise InputError(f"{flag} is an option of {s.title}, which is not computed: "
                             f"{s.switch_on} (or {s.name} to --metrics), or drop "
                             f"{flag.split()[0]}")
    return out


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="dynaeval",
        description="Score novel views of dynamic scenes: whole-frame, focused, masked and "
                    "temporal metrics.",
    )
    parser.add_argument("--version", action="version", version=f"dynaeval {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("score", help="score predicted frames against ground truth",
                       description="Score PRED frames against GT frames (folders of images, one "
                                   "sub-folder per camera, or videos), or one render folder of "
                                   "NeRFBaselines (color/ + gt-color/), ns-render (rgb/ + "
                                   "gt-rgb/), the 3DGS family (MODEL or MODEL/test/ours_N), "
                                   "DyCheck, or a K-Planes step<N>.mp4 / log folder: "
                                   "docs/integration.md.")
    p.add_argument("pred", help="folder of predicted frames, or a render folder")
    p.add_argument("gt", nargs="?",
                   help="folder of ground-truth frames, same layout (omit for a render folder)")
    _add_score_options(p)

    m = sub.add_parser("merge", help="combine the results of 'score --shard I/N' runs",
                       description="Merge the results files of all N shards of one scoring run "
                                   "into the results of the unsharded run (same numbers, bit for "
                                   "bit).")
    m.add_argument("parts", nargs="+", metavar="PART.json")
    m.add_argument("-o", "--output", required=True, metavar="results.json",
                   help=f"the merged results file ({FOLDERS_RULE})")
    m.add_argument("--overwrite", action="store_true", help="replace an existing -o file")

    t = sub.add_parser("detect", help="find boxes in ground-truth frames once, for --focus boxes:FILE",
                       description="Write the boxes of every ground-truth frame (raw, unexpanded) "
                                   "to a boxes file that 'score --focus boxes:FILE' reuses, so "
                                   "every method is scored on the same pixels.")
    t.add_argument("gt", help="folder of ground-truth frames")
    t.add_argument("-o", "--output", required=True, metavar="boxes.json",
                   help=f"the boxes file to write ({FOLDERS_RULE})")
    t.add_argument("--source", choices=["detector", "motion"], default="detector",
                   help="ONNX detector (default) or connected components of the motion masks")
    t.add_argument("--detector", metavar="MODEL.onnx|NAME",
                   help="ONNX detector, or a name fetched with 'dynaeval detector fetch' "
                        "(default: the one shipped with dynaeval)")
    _add_classes_flag(t)
    t.add_argument("--device", choices=["cpu", "cuda"], default="cpu")
    t.add_argument("--overwrite", action="store_true", help="replace an existing -o file")
    t.add_argument("-q", "--quiet", action="store_true", help="no progress bar")

    _add_detector_command(sub)

    _add_prepare_command(sub)
    add_suite_command(sub)
    lb = sub.add_parser("leaderboard", help="combine results files into one table",
                        description="Combine results files (methods x scenes) into one table: "
                                    "means per scene and overall (mean of scene means) with "
                                    "bootstrap intervals over frames. Files whose number-changing "
                                    "settings differ are refused unless --force.")
    lb.add_argument("results", nargs="+", metavar="RESULTS.json")
    lb.add_argument("--format", choices=["md", "csv", "json", "html"], default="md",
                    help="output format (default: md)")
    lb.add_argument("--by", choices=["method", "scene"], default="method",
                    help="group rows by method (default) or by scene")
    lb.add_argument("--metrics", nargs="+", metavar="NAME",
                    help="metrics to show (default: every metric of the files)")
    lb.add_argument("--force", action="store_true",
                    help="combine files even when settings differ (the differences are recorded)")
    lb.add_argument("-o", "--output", metavar="FILE",
                    help=f"write here (atomically; {FOLDERS_RULE}) instead of stdout")
    lb.add_argument("--overwrite", action="store_true", help="replace an existing -o file")

    d = sub.add_parser("demo", help="score the sample scene shipped with dynaeval",
                       description="Score the bundled sample predictions against the bundled "
                                   "ground truth, print the table and write results JSON.")
    d.add_argument("-o", "--output", default="dynaeval-demo-results.json", metavar="results.json",
                   help="where to write the results (default: %(default)s, replaced if present)")
    _add_metric_flags(d)
    d.add_argument("--report", metavar="DIR", help="also write an HTML report into DIR")
    d.set_defaults(focus=f"boxes:{sample_dir() / 'boxes.json'}")
    d.add_argument("--workers", type=int, default=_defaults().workers, metavar="N")
    d.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    return parser


def _add_prepare_command(sub: Any) -> None:
    d = _defaults()
    r = sub.add_parser("prepare", help="compute what depends on the ground truth alone, once",
                       description="Write GT's regions (boxes, motion masks) and ground-truth "
                                   "optical flows to PREP, for 'dynaeval score PRED GT --prepared "
                                   "PREP' (same numbers, faster): docs/performance.md. Pass the "
                                   "options the scoring runs will use.")
    r.add_argument("gt", help="folder of ground-truth frames (as given to 'dynaeval score')")
    r.add_argument("-o", "--output", required=True, metavar="PREP",
                   help=f"folder to write ({FOLDERS_RULE})")
    r.add_argument("--overwrite", action="store_true", help="replace an existing PREP folder")
    for flag, kw in (
        ("--focus", {"default": d.focus.source, "metavar": "detector|motion|boxes:FILE|none"}),
        ("--detector", {"metavar": "MODEL.onnx|NAME"}),
        ("--expand", {"choices": ["paper", "margin", "none"], "default": d.focus.expand}),
        ("--no-masked", {"action": "store_true"}), ("--no-temporal", {"action": "store_true"}),
        ("--flow", {"choices": FLOW_METHODS, "default": d.flow}),
        ("--background", {"choices": BACKGROUNDS, "default": d.background}),
        ("--quantize", {"choices": QUANTIZE_MODES, "default": d.quantize}),
        ("--protocol", {"choices": PROTOCOL_NAMES, "default": d.protocol}),
        ("--workers", {"type": int, "default": d.workers, "metavar": "N"}),
        ("--cache-mb", {"type": int, "default": d.cache_mb, "metavar": "MB"}),
    ):
        r.add_argument(flag, help="as for 'dynaeval score'", **kw)
    _add_classes_flag(r)
    r.add_argument("-q", "--quiet", action="store_true", help="no progress bar")


def _run_prepare(args: argparse.Namespace) -> int:
    manifest = prepare(args.gt, args.output, config_from_args(args), overwrite=args.overwrite)
    n_flows = sum(len(c["flows"] or ()) * 2 for c in manifest["cameras"].values())
    print(f"{len(manifest['files'])} ground-truth files, {len(manifest['cameras'])} cameras, "
          f"{n_flows} flows prepared in {args.output} (id {manifest['id']})")
    return EXIT_OK


def _add_detector_command(sub: Any) -> None:
    dp = sub.add_parser("detector", help="fetch COCO detectors (ONNX) for --detector NAME",
                        description="Fetch a COCO-trained detector once (its weights downloaded "
                                    "by torchvision or Ultralytics, exported to ONNX into the "
                                    f"user cache, ${CACHE_ENV} to override), then score with "
                                    "--detector NAME.")
    dsub = dp.add_subparsers(dest="detector_command", required=True, metavar="ACTION")
    f = dsub.add_parser("fetch", help="download, export and store a detector",
                        description="; ".join(f"{k}: {v.description}" for k, v in KNOWN.items()))
    f.add_argument("name", choices=list(KNOWN), metavar="NAME", help=", ".join(KNOWN))
    f.add_argument("--overwrite", action="store_true", help="fetch again over a fetched copy")
    dsub.add_parser("list", help="the fetched detectors and the known names not fetched yet")


def _run_detector(args: argparse.Namespace) -> int:
    if args.detector_command == "fetch":
        path = fetch.fetch(args.name, overwrite=args.overwrite)
        print(f"detector {args.name!r} written to {path} (provenance: "
              f"{path.with_suffix('.json')}); score with --detector {args.name}")
        return EXIT_OK
    print(f"detectors in {fetch.cache_dir()}:")
    for row in fetch.list_detectors():
        state = f"fetched {row['date'] or ''}".strip() if row["fetched"] else "not fetched"
        print(f"  {row['name']:<22} {state:<36} {row['description']}")
    return EXIT_OK


def _print_warnings(results: dict, output: str | None = None) -> None:
    """The run's warnings on stderr: run-level and whole-camera ones each, then the per-frame
    and per-camera-metric ones grouped by reason (``_print_frame_warnings``); ``output``: the
    results file written (None: the console is the only place the user sees them)."""
    for w in results["warnings"]:
        if "camera" not in w:  # run-level warnings
            print(f"dynaeval: warning: {warning_text(w)}", file=sys.stderr)
    _print_regions(results)
    for w in results["warnings"]:  # about a whole camera (its motion masks, its frames' sizes)
        if "camera" in w and "frame" not in w and "metric" not in w:
            print(f"dynaeval: warning: camera {w['camera']}: {w['reason']}", file=sys.stderr)
    _print_frame_warnings([w for w in results["warnings"]
                           if "camera" in w and ("frame" in w or "metric" in w)], output)
    cams = results["inputs"]["unscored_cameras"]
    if cams:
        print(f"dynaeval: {len(cams)} ground-truth camera(s) without predictions not scored: "
              f"{', '.join(cams[:8])}{' …' if len(cams) > 8 else ''}", file=sys.stderr)


def _print_frame_warnings(warnings: list[dict], output: str | None, most: int = 5) -> None:
    """Warnings about single frames (or one metric of a camera), one line per distinct reason
    with how many frames and cameras it concerns, the ``most`` commonest first; the others
    summarised with a count, pointing at ``output`` if it was written, else at ``-o``."""
    from collections import Counter

    texts = [warning_text(w) for w in warnings]
    groups = Counter(texts)
    cameras: dict[str, set[str]] = {}
    frames: Counter[str] = Counter()
    for w, text in zip(warnings, texts, strict=True):
        cameras.setdefault(text, set()).add(w["camera"])
        frames[text] += "frame" in w
    for text, _ in groups.most_common(most):
        where = f"{len(cameras[text])} camera(s)"
        where = f"{frames[text]} frame(s) in {where}" if frames[text] else where
        print(f"dynaeval: warning: {text} ({where})", file=sys.stderr)
    rest = sum(n for _, n in groups.most_common()[most:])
    if rest:
        kept = f"all listed in {output}" if output else "pass -o results.json to keep them all"
        print(f"dynaeval: {rest} more warning(s) about single frames or cameras, of "
              f"{len(groups) - most} other kind(s) ({kept})", file=sys.stderr)


def _print_regions(results: dict, most: int = 12) -> None:
    """One line per camera (at most ``most``): the boxes its regions hold."""
    regions = results.get("regions") or {}
    cameras = regions.get("cameras", {}) if regions.get("source") != "none" else {}
    for cam, summary in list(cameras.items())[:most]:
        print(f"dynaeval: regions: {describe_regions(cam, summary)}", file=sys.stderr)
    if len(cameras) > most:
        print(f"dynaeval: regions: {len(cameras) - most} more camera(s) in the results JSON "
              "('regions')", file=sys.stderr)


def _print_gs_written(results: dict, folder: str) -> None:
    paths = gs_paths(folder)
    print(f"3DGS results written to {paths[0]} and {paths[1]}", file=sys.stderr)
    name = results["settings"]["protocol"]["name"]
    if name not in ("3dgs", "4dgaussians"):
        print(f"dynaeval: warning: these files hold --protocol {name} numbers, not the 3DGS "
              "family's own (pass --protocol 3dgs, or 4dgaussians, for those)", file=sys.stderr)


def _run_score(pred: str, gt: str | None, args: argparse.Namespace, *, overwrite: bool) -> int:
    import warnings

    output = getattr(args, "output", None)
    report = getattr(args, "report", None)
    config = config_from_args(args)
    inputs = [pred, gt, config.focus.boxes_file, config.focus.detector_model]
    # every output checked before the long run (and before reading a frame)
    check_writable(output, overwrite=overwrite, what="results file", inputs=inputs)
    check_writable(report, overwrite=overwrite, what="report folder", inputs=inputs, folder=True)
    gs_json = getattr(args, "gs_json", None)
    if gs_json:
        for path in gs_paths(gs_json):
            check_writable(path, overwrite=overwrite, what="3DGS results file", inputs=inputs)
    if report and (Path(report) / "index.html").exists() and not overwrite:
        raise InputError("report exists; pass --overwrite or choose another --report folder",
                         path=Path(report) / "index.html")
    if args.command == "demo":
        from dataclasses import replace

        config = replace(config, method="sample-degraded", scene="sample")
    recorder = None
    if report:
        recorder = RegionRecorder()
    with warnings.catch_warnings():  # printed below, from the results, once
        warnings.simplefilter("ignore", DynaevalWarning)
        results = score(pred, gt, config, on_regions=recorder)
    layout = results["inputs"].get("layout")
    if layout and layout["name"] == "kplanes":
        files = layout["stack"]["files"]
        shown = files[0] if len(files) == 1 else f"{len(files)} files ({files[0]}, ...)"
        print(f"dynaeval: K-Planes evaluation stack: scored the top third (prediction) of "
              f"{shown} against its middle third (ground truth)", file=sys.stderr)
    elif layout:
        print(f"dynaeval: {layout['name']} render folder: scored {results['inputs']['pred']} "
              f"against {results['inputs']['gt']}", file=sys.stderr)
    _print_warnings(results, output)
    _write_score_outputs(results, args, recorder, overwrite=overwrite)
    print(summary_table(results))
    return EXIT_OK


def _write_score_outputs(results: dict, args: argparse.Namespace, recorder: Any, *,
                         overwrite: bool) -> None:
    """Write the results file, the 3DGS files and the report as one (``write_files_atomic``):
    all of them or, on a full disk or an interrupt, none, with existing files as they were."""
    output, report = getattr(args, "output", None), getattr(args, "report", None)
    gs_json = getattr(args, "gs_json", None)
    files = [(Path(output), results_text(results), "results file")] if output else []
    if gs_json:
        files += gs_files(results, gs_json)
    if report:
        files.append((report_index(report, overwrite=overwrite),
                      render_report(results, recorder=recorder), "report"))
    write_files_atomic(files, overwrite=overwrite)
    if output:
        print(f"results written to {output}", file=sys.stderr)
    else:
        print("(pass -o results.json to save the per-frame results)", file=sys.stderr)
    if gs_json:
        _print_gs_written(results, gs_json)
    if report:
        print(f"report written to {Path(report) / 'index.html'}", file=sys.stderr)


def _run_detect(args: argparse.Namespace) -> int:
    if args.detector and args.source != "detector":
        raise InputError(f"--detector is only used with --source detector (got --source "
                         f"{args.source}): drop --detector, or pass --source detector")
    check_writable(args.output, overwrite=args.overwrite, what="boxes file",
                   inputs=[args.gt, args.detector])
    notes: list[dict] = []
    mapping, source = detect_ground_truth(args.gt, source=args.source,
                                          detector_model=args.detector, device=args.device,
                                          progress=not args.quiet,
                                          classes=parse_classes(args.classes), warnings=notes)
    for note in notes:
        where = f"camera {note['camera']}: " if "camera" in note else ""
        print(f"dynaeval: warning: {where}{note['reason']}", file=sys.stderr)
    write_boxes_file(args.output, mapping, source, overwrite=args.overwrite)
    n_boxes = sum(len(v) for v in mapping.values())
    empty = sum(not v for v in mapping.values())
    print(f"{n_boxes} boxes in {len(mapping)} frames ({empty} without any) written to "
          f"{args.output}")
    return EXIT_OK


def _run_leaderboard(args: argparse.Namespace) -> int:
    check_writable(args.output, overwrite=args.overwrite, what="leaderboard file",
                   inputs=args.results)
    board = build_leaderboard(args.results, force=args.force, metrics=args.metrics)
    text = render(board, args.format, args.by)
    for f in forced_fields(board):
        print(f"dynaeval: warning: combined despite differing setting {f!r} (--force)",
              file=sys.stderr)
    if args.output:
        write_text_atomic(args.output, text, overwrite=args.overwrite, what="leaderboard file")
        print(f"leaderboard written to {args.output}", file=sys.stderr)
    else:
        sys.stdout.write(text)
    return EXIT_OK


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``dynaeval`` command; returns the exit code."""
    args = build_parser().parse_args(argv)
    keep_freed_memory(getattr(args, "workers", 1) or 1)
    try:
        if note := check_opencv(needs_tvl1=getattr(args, "flow", None) == "tvl1"):
            print(f"dynaeval: warning: {note}", file=sys.stderr)
        if args.command == "score":
            return _run_score(args.pred, args.gt, args, overwrite=args.overwrite)
        if args.command == "merge":
            check_writable(args.output, overwrite=args.overwrite, what="results file",
                           inputs=args.parts)
            merged = merge_results(args.parts)
            write_json_atomic(args.output, merged, overwrite=args.overwrite)
            print(f"{len(args.parts)} shards, {merged['summary']['n_frames']} frames merged into "
                  f"{args.output}", file=sys.stderr)
            return EXIT_OK
        if args.command == "detect":
            return _run_detect(args)
        if args.command == "leaderboard":
            return _run_leaderboard(args)
        if args.command == "prepare":
            return _run_prepare(args)
        if args.command == "detector":
            return _run_detector(args)
        if args.command == "suite":
            return run_suite_command(args)
        if args.command == "demo":
            root = sample_dir()
            if not (root / "pred").is_dir():
                raise InputError("the sample scene is missing from this installation", path=root)
            return _run_score(str(root / "pred"), str(root / "gt"), args, overwrite=True)
        raise AssertionError(args.command)  # argparse restricts the choices
    except InputError as err:
        print(f"dynaeval: error: {err}", file=sys.stderr)
        return EXIT_INPUT
    except BrokenPipeError:  # stdout closed early (| head): the work is done, stay quiet
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_OK
    except KeyboardInterrupt:
        print("dynaeval: interrupted; no results written", file=sys.stderr)
        return 130
    except Exception:
        traceback.print_exc()
        print("dynaeval: internal error (a bug): please report it with the traceback above",
              file=sys.stderr)
        return EXIT_BUG


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
