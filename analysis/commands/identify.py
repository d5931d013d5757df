"""``posfb identify``: theta_1..theta_11 of Sec. 4.1 identified from the URDF
plant, printed beside Table 1 (or as JSON)."""

from __future__ import annotations

import argparse
import json

from posfb.analysis.tables import theta_table
from posfb.models.identify import identify_urdf
from posfb.models.plant import DEFAULT_URDF


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "identify", help="identify theta_1..theta_11 (Sec. 4.1) from the URDF plant"
    )
    parser.add_argument("--urdf", default=str(DEFAULT_URDF), help="arm URDF (default: shipped)")
    parser.add_argument("--payload", type=float, default=0.0, help="tip payload mass in kg")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    identified = identify_urdf(args.urdf, args.payload)
    if args.json:
        print(json.dumps(identified.as_dict()))
    else:
        print(f"theta identified from {args.urdf} with a {args.payload:g} kg tip payload")
        print(theta_table({"identified": identified}))
    return 0
