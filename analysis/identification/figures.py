"""The figure of ``posfb identify --validate --figure``: per joint, the applied voltage
against the model's (both filtered) and the measured position against the model driven
by the log's voltages from the start of each window."""

from __future__ import annotations

from pathlib import Path

from posfb.models.identification.validation import Validation


def validation_figure(validation: Validation, path: Path) -> None:
    """Draw ``validation`` into ``path`` (format from its suffix)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    joints = validation.voltage.shape[1]
    figure, axes = plt.subplots(2, joints, figsize=(6.5 * joints / 2 + 1.5, 5.5), squeeze=False)
    for j in range(joints):
        top, bottom = axes[0, j], axes[1, j]
        top.plot(validation.time, validation.voltage[:, j], lw=1.0, label="applied")
        top.plot(validation.time, validation.predicted_voltage[:, j], lw=1.0, ls="--",
                 label="model")  # fmt: skip
        top.set_title(f"joint {j + 1}: voltage NRMSE {validation.voltage_nrmse[j]:.1f} %")
        top.set_ylabel("u (V, filtered)")
        bottom.plot(validation.position_time, validation.position[:, j], ".", ms=1.0,
                    label="measured")  # fmt: skip
        bottom.plot(validation.position_time, validation.simulated_position[:, j], ".",
                    ms=1.0, label=f"model, {validation.window:g} s windows")  # fmt: skip
        bottom.set_title(f"output error NRMSE {validation.output_nrmse[j]:.1f} %")
        bottom.set_ylabel("q (rad)")
        bottom.set_xlabel("t (s)")
        for axis in (top, bottom):
            axis.legend(loc="upper right", fontsize=7)
            axis.grid(alpha=0.3)
    figure.tight_layout()
    figure.savefig(path)
    plt.close(figure)
