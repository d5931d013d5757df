"""sphinx-gallery hooks for posfb's examples gallery (``docs/conf.py``).

The scripts in ``examples/`` are command-line programs: ``main`` reads its options with
argparse and writes its figures to the file or folder ``--out`` names (no pyplot, so the
default matplotlib scraper sees nothing). For the gallery each runs with short options
(``ARGUMENTS``: the durations and plant counts of the test suite, so the build stays
short) and an ``--out`` inside a scratch folder; ``saved_figures`` then shows the PNG files
the script wrote there.

The names are given to sphinx-gallery as strings (``"gallery_hooks.reset_argv"``), so that
the configuration stays picklable (a Sphinx warning otherwise, an error under ``-W``).
"""

from __future__ import annotations

import ast
import shutil
import tempfile
from pathlib import Path

from sphinx_gallery.scrapers import figure_rst

#: Script name -> its command-line options in the gallery; ``{out}`` is the scratch
#: folder of that script. Each option is one the script's own parser defines.
ARGUMENTS = {
    "compare_my_scenario": ["--duration", "1", "--out", "{out}"],
    "disturbance_torque": ["--duration", "2"],
    "my_controller": ["--duration", "1"],
    "nonidealities": ["--duration", "0.5", "--out", "{out}/effects.png"],
    "robust_tuning": ["--plants", "20", "--out", "{out}/tuned.yaml"],
    "sample_time_sweep": ["--duration", "1", "--out", "{out}/sweep.png"],
}

#: Where the scripts write (one folder per script, emptied before it runs).
SCRATCH = Path(tempfile.gettempdir()) / "posfb-gallery"


def _scratch(src_file: str) -> Path:
    return SCRATCH / Path(src_file).stem


def reset_argv(gallery_conf: dict, script_vars: dict) -> list[str]:
    """The options of the script about to run (``sys.argv[1:]``).

    sphinx-gallery runs a script without ``__file__`` and with an empty ``__doc__``; a
    script may read either (the plug-in example copies itself next to its scenario, every
    parser takes its description from the docstring), so both are set here as ``python
    examples/NAME.py`` sets them."""
    src_file = script_vars["src_file"]
    out = _scratch(src_file)
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir(parents=True)
    script_vars["example_globals"]["__file__"] = str(src_file)
    script_vars["example_globals"]["__doc__"] = ast.get_docstring(
        ast.parse(Path(src_file).read_text()), clean=False
    )
    options = ARGUMENTS.get(Path(src_file).stem, [])
    return [option.format(out=out) for option in options]


def saved_figures(block, block_vars: dict, gallery_conf: dict, **kwargs) -> str:
    """The PNG files the script wrote into its scratch folder since the last block, copied
    to sphinx-gallery's image paths and shown below the block's output."""
    out = _scratch(block_vars["src_file"])
    shown = block_vars.setdefault("posfb_shown", set())
    new = sorted(p for p in out.rglob("*.png") if p not in shown)
    images = []
    for path, target in zip(new, block_vars["image_path_iterator"], strict=False):
        shutil.copyfile(path, target)
        shown.add(path)
        images.append(target)
    return figure_rst(images, gallery_conf["src_dir"]) if images else ""
