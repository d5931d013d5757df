"""``posfb simulate``: one closed-loop run of Sec. 4 (one controller, one case)."""

from __future__ import annotations

import argparse
import json

from posfb.analysis.experiment import CASES, CONTROLLER_LABELS, result_entry, run_case
from posfb.diagrams.closed_loop import ClosedLoopConfig
from posfb.diagrams.encoder import DEFAULT_ENCODER_COUNTS
from posfb.models.controllers import CONTROLLER_KINDS


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "simulate", help="one closed-loop run (Sec. 4): RMS errors and voltages"
    )
    parser.add_argument("--controller", choices=CONTROLLER_KINDS, default="proposed")
    parser.add_argument("--case", choices=CASES, default="nominal")
    parser.add_argument("--duration", type=float, default=20.0, help="simulated seconds")
    parser.add_argument("--sample-time", type=float, default=0.01, help="T_s in seconds")
    parser.add_argument(
        "--encoder-counts",
        type=int,
        default=DEFAULT_ENCODER_COUNTS,
        help="encoder counts per joint revolution (0: ideal sensor)",
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    config = ClosedLoopConfig(
        controller=args.controller,
        duration=args.duration,
        sample_time=args.sample_time,
        encoder_counts=args.encoder_counts,
    )
    result = run_case(args.controller, args.case, config)
    summary = {
        "controller": args.controller,
        "case": args.case,
        "duration": args.duration,
        "sample_time": args.sample_time,
        "encoder_counts": args.encoder_counts,
        **result_entry(result),
    }
    if args.json:
        print(json.dumps(summary))
        return 0
    m, label = result.metrics, CONTROLLER_LABELS[args.controller]
    print(f"{label}, {args.case} arm, {args.duration:g} s: {result.status}")
    if result.message:
        print(f"  {result.message}")
    print(f"  RMS(q~) = ({m.rms_q[0]:.5f}, {m.rms_q[1]:.5f}) rad, max |q~| = {m.max_abs_q_err:.5f}")
    print(f"  RMS(u)  = ({m.rms_u[0]:.3f}, {m.rms_u[1]:.3f}) V applied")
    print(f"  saturated: {100 * m.saturated_fraction:.1f} % of the samples")
    rate = args.duration / m.wall_time_s
    print(f"  wall time {m.wall_time_s:.2f} s ({rate:.1f} simulated s per wall s)")
    return 0
