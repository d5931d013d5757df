"""``posfb identify``: theta_1..theta_11 of Sec. 4.1 identified from the URDF
plant, printed beside Table 1 (or as JSON)."""

from __future__ import annotations

import argparse
import json

from posfb.analysis.tables import theta_table
from posfb.models.identify import identify
from posfb.models.lumped import LumpedParameters
from posfb.models.plant import (
    DEFAULT_URDF,
    PlantConfig,
    apply_parameters,
    build_arm_diagram,
    require_payload_mass,
)


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "identify", help="identify theta_1..theta_11 (Sec. 4.1) from the URDF plant"
    )
    parser.add_argument("--urdf", default=str(DEFAULT_URDF), help="arm URDF (default: shipped)")
    parser.add_argument("--payload", type=float, default=0.0, help="tip payload mass in kg")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.set_defaults(handler=run)


def identify_urdf(urdf: str, payload: float) -> LumpedParameters:
    """theta of the URDF plant with ``payload`` kg at the link-2 tip (refused,
    naming ``payload_mass``, outside 0..``MAX_PAYLOAD_MASS`` kg)."""
    require_payload_mass(payload)
    _, arm, context = build_arm_diagram(PlantConfig(urdf=urdf))
    apply_parameters(arm, context, arm.default_parameters.with_payload(payload))
    return identify(arm, context)


def run(args: argparse.Namespace) -> int:
    identified = identify_urdf(args.urdf, args.payload)
    if args.json:
        print(json.dumps(identified.as_dict()))
    else:
        print(f"theta identified from {args.urdf} with a {args.payload:g} kg tip payload")
        print(theta_table({"identified": identified}))
    return 0
