"""Package discovery for posfb's layout (the rest of the build is ``pyproject.toml``).

The repository's top-level folders ``models/``, ``diagrams/``, ``analysis/`` and
``urdf/`` are installed as ``posfb.models``, ``posfb.diagrams``, ``posfb.analysis`` and
``posfb.urdf``, and every folder below them is a subpackage (a data folder such as
``analysis/studies/`` one without an ``__init__.py``): found here, not listed by hand,
so that a new one ships without an edit.
"""

from setuptools import find_namespace_packages, setup

#: posfb's subpackages -> the repository folder each is installed from.
LAYERS = {f"posfb.{folder}": folder for folder in ("models", "diagrams", "analysis", "urdf")}

setup(
    packages=[
        "posfb",
        *LAYERS,
        *(
            f"{package}.{sub}"
            for package, folder in LAYERS.items()
            for sub in find_namespace_packages(where=folder, exclude=["*__pycache__*"])
        ),
    ],
    package_dir={"posfb": "posfb", **LAYERS},
)
