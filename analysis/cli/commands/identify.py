"""``posfb identify``: theta_1..theta_11 of Sec. 4.1 identified from the URDF
plant, printed beside Table 1 (or as JSON)."""

from __future__ import annotations

import argparse
import json


def configure(parser: argparse.ArgumentParser) -> None:
    # No default here: the shipped URDF's path is ``models.plant.DEFAULT_URDF``, which
    # imports Drake; ``run`` reads it.
    parser.add_argument("--urdf", help="arm URDF (default: the shipped two-link arm)")
    parser.add_argument("--payload", type=float, default=0.0, help="tip payload mass in kg")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from posfb.analysis.common.tables import theta_table
    from posfb.models.identify import identify_urdf
    from posfb.models.plant import DEFAULT_URDF

    urdf = args.urdf or str(DEFAULT_URDF)
    identified = identify_urdf(urdf, args.payload)
    if args.json:
        print(json.dumps(identified.as_dict()))
    else:
        print(f"theta identified from {urdf} with a {args.payload:g} kg tip payload")
        print(theta_table({"identified": identified}))
    return 0
