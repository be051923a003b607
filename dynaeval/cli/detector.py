"""``dynaeval detector fetch NAME`` / ``list``: COCO detectors in the user cache."""

from __future__ import annotations

import argparse
from typing import Any

from dynaeval.regions import fetch
from dynaeval.regions.fetch import CACHE_ENV, KNOWN

from .common import EXIT_OK

NAME = "detector"


def add(sub: Any) -> None:
    dp = sub.add_parser(NAME, help="fetch COCO detectors (ONNX) for --detector NAME",
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


def run(args: argparse.Namespace) -> int:
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
