"""The arms shipped with posfb, as URDF files (``urdf/README.md`` says where every
number comes from). The folder is installed as the package ``posfb.urdf`` so that its
files travel in the wheel; a scenario names one as ``package://posfb/NAME.urdf``."""
