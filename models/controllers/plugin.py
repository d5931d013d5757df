"""Your own controller: the public contract (``posfb.Controller``) and the Drake system
that runs it in posfb's closed loop (``PluginSystem``).

A plug-in is a plain Python class; posfb wraps it in the same discrete system as its
built-in controllers (``models.controllers.base.SampledController``): both inputs held
by zero-order holds, direct feedthrough, so the voltage computed from the measurement
at ``t_k`` is applied on ``[t_k, t_k + T_s)``. The plug-in never gets a velocity: its
only measurement is the held, quantised joint position (position-only is structural,
``tests/test_controller_plugins.py`` checks it on the diagram).

The contract, in the order posfb calls it:

1. ``__init__(self, setup, **settings)``: ``setup`` is a ``ControllerSetup``
   (``sample_time``, ``joints``, ``voltage_limit`` and the scenario's ``nominal`` model),
   ``settings`` the scenario's ``settings:`` map (numbers, lists, strings as written).
2. ``memory_size`` (int) and ``internals`` (column names, each ending in its unit:
   ``d_hat_1_V``, ``v_est_2_rad_per_s``), read once after ``__init__``; class
   attributes or properties.
3. ``start(q, desired) -> memory``: the controller's memory (``memory_size`` floats)
   before the first sample, from the first measurement ``q`` (n) and ``desired``.
4. ``step(q, desired, memory) -> (voltage, internals)`` at every sample ``t_k``:
   ``q`` the held quantised position (n, rad), ``desired`` the stacked
   ``[q_d, qdot_d, qddot_d]`` (3n); ``voltage`` (n, V, before the ±``voltage_limit``
   saturation) and ``internals`` (as many values as names). ``memory`` is the plug-in's
   to update **in place** (``memory[:] = ...``): what it holds after ``step`` is the
   memory of the next sample.

Wrong sizes or non-finite output are refused in one line naming the class and its file
(``PluginError``); an exception raised inside the plug-in's own code propagates as it
is, with the plug-in's frames in its traceback.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import sys
import traceback
import types
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from posfb.models.controllers.base import SampledController
from posfb.models.controllers.registry import ControllerBuild, ControllerSpec
from posfb.models.nominal import nominal_model


class PluginError(ValueError):
    """A plug-in broke the contract (bad class, sizes, non-finite output): one line."""


#: The source files of the user plug-ins loaded in this process: an error raised in
#: their code is shown with their frames only (``user_frames``).
USER_SOURCES: set[str] = set()


def user_frames(error: BaseException) -> list[traceback.FrameSummary]:
    """The frames of ``error``'s traceback that are in a user plug-in's source."""
    return [f for f in traceback.extract_tb(error.__traceback__) if f.filename in USER_SOURCES]


class NominalDynamics:
    """The scenario's nominal model as a plug-in sees it: joint ``i``'s equation of
    motion divided by its motor constant (``models.lumped``, reading note 9), so every
    "torque" is an armature voltage (V) and ``mass_matrix`` is in V s^2/rad."""

    def __init__(self, model: object) -> None:
        self._model = model

    def inverse_dynamics(
        self, q: np.ndarray, qdot: np.ndarray, qddot: np.ndarray
    ) -> np.ndarray:
        """``M(q) qddot + C(q, qdot) qdot + G(q) + B qdot`` (V): the voltage that makes
        the nominal arm (without Coulomb friction) follow ``(q, qdot, qddot)``."""
        return np.asarray(self._model.inverse_dynamics(q, qdot, qddot), dtype=float)

    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        """``M(q)`` (n x n, V s^2/rad)."""
        return np.asarray(self._model.M(q), dtype=float)

    def gravity(self, q: np.ndarray) -> np.ndarray:
        """``G(q)`` (n, V)."""
        return np.asarray(self._model.G(q), dtype=float)

    def viscous(self) -> np.ndarray:
        """``B`` (n x n, V s/rad): the viscous friction matrix."""
        return np.asarray(self._model.B(), dtype=float)

    def coulomb_levels(self) -> np.ndarray:
        """The Coulomb friction levels (n, V)."""
        return np.asarray(self._model.coulomb_levels(), dtype=float)

    def mean_mass_matrix(self) -> np.ndarray:
        """``M0`` (n x n, V s^2/rad): the configuration-independent part of ``M(q)`` (Table
        1's closed form; for a URDF model, the mean over the joint angles), the inertia
        a fixed-gain tuning rule scales its gains by."""
        return np.asarray(self._model.M0(), dtype=float)


@dataclass(frozen=True)
class ControllerSetup:
    """What a controller is designed for: the sample time ``T_s`` (s), the number of
    joints ``n``, the voltage limit per joint (V) and the nominal model."""

    sample_time: float
    joints: int
    voltage_limit: tuple[float, ...]
    nominal: NominalDynamics


class Controller:
    """Base class of a position-only controller plug-in (module docstring: the contract).

    Examples
    --------
    A proportional controller with gravity compensation::

        import numpy as np
        import posfb

        class PGravity(posfb.Controller):
            memory_size = 0

            def __init__(self, setup, Kp=20.0):
                super().__init__(setup)
                self.Kp = np.broadcast_to(np.asarray(Kp, dtype=float), (setup.joints,))
                self.internals = tuple(f"g_{j + 1}_V" for j in range(setup.joints))

            def step(self, q, desired, memory):
                q_d = desired[: self.setup.joints]
                gravity = self.setup.nominal.gravity(q)
                return self.Kp * (q_d - q) + gravity, gravity
    """

    #: Floats of memory the controller keeps between samples (a class attribute, or an
    #: instance attribute set in ``__init__``).
    memory_size: int = 0
    #: Names of the ``internals`` values, each ending in its unit.
    internals: tuple[str, ...] = ()

    def __init__(self, setup: ControllerSetup, **settings: object) -> None:
        if settings:
            raise PluginError(
                f"{type(self).__name__} takes no settings, got {', '.join(sorted(settings))}"
            )
        self.setup = setup

    def start(self, q: np.ndarray, desired: np.ndarray) -> np.ndarray:
        """The memory before the first sample (default: zeros)."""
        return np.zeros(self.memory_size)

    def step(
        self, q: np.ndarray, desired: np.ndarray, memory: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(voltage, internals)`` at this sample; updates ``memory`` in place."""
        raise NotImplementedError(f"{type(self).__name__}.step is not written")


def plugin_where(controller: Controller) -> str:
    """``Class (file)`` for messages."""
    import inspect

    cls = type(controller)
    try:
        source = inspect.getsourcefile(cls) or cls.__module__
    except TypeError:
        source = cls.__module__
    return f"{cls.__name__} ({source})"


def _names(value: object, where: str) -> tuple[str, ...]:
    if isinstance(value, str) or not isinstance(value, Sequence):
        raise PluginError(f"{where}: internals = {value!r}; a sequence of column names is required")
    names = tuple(value)
    if not all(isinstance(name, str) and name for name in names):
        raise PluginError(f"{where}: internals = {value!r}; non-empty strings are required")
    if len(set(names)) != len(names):
        raise PluginError(f"{where}: internals = {value!r} names a column twice")
    return names


class PluginSystem(SampledController):
    """A ``Controller`` plug-in as a discrete Drake system (``SampledController``'s
    ports, timing and state), its output checked at every sample. Its internals'
    names carry their units already, so they are its export columns."""

    def __init__(self, controller: Controller) -> None:
        if not isinstance(controller, Controller):
            raise PluginError(f"{controller!r} is not a posfb.Controller")
        where = plugin_where(controller)
        memory = controller.memory_size
        if isinstance(memory, bool) or not isinstance(memory, int | np.integer) or memory < 0:
            raise PluginError(f"{where}: memory_size = {memory!r}; an integer >= 0 is required")
        setup = controller.setup
        names = _names(controller.internals, where)
        super().__init__(setup.sample_time, setup.joints, names, int(memory))
        self.plugin = controller
        self._where = where
        self.set_name(f"{type(controller).__name__}_controller")

    @property
    def internals_columns(self) -> tuple[str, ...]:
        return self.internals_names

    def _start(self, q: np.ndarray, desired: np.ndarray) -> np.ndarray:
        memory = np.array(self.plugin.start(q.copy(), desired.copy()), dtype=float).ravel()
        if memory.shape != (self.memory_size,):
            raise PluginError(
                f"{self._where}: start returned {memory.shape[0]} memory values; "
                f"memory_size = {self.memory_size} is required"
            )
        return memory

    def _step(
        self, q: np.ndarray, desired: np.ndarray, memory: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        result = self.plugin.step(q.copy(), desired.copy(), memory)
        if not isinstance(result, tuple) or len(result) != 2:
            raise PluginError(f"{self._where}: step returned {type(result).__name__}; "
                              "a pair (voltage, internals) is required")  # fmt: skip
        voltage = np.asarray(result[0], dtype=float).ravel()
        internals = np.asarray(result[1], dtype=float).ravel()
        for name, value, size in (
            ("voltage", voltage, self.joints),
            ("internals", internals, len(self.internals_names)),
        ):
            if value.shape != (size,):
                raise PluginError(
                    f"{self._where}: step returned {value.shape[0]} {name} values; {size} "
                    "are required"
                )
            if not np.all(np.isfinite(value)):
                raise PluginError(
                    f"{self._where}: step returned a non-finite {name} {value.tolist()}"
                )
        if memory.shape != (self.memory_size,) or not np.all(np.isfinite(memory)):
            raise PluginError(f"{self._where}: step left a non-finite or resized memory")
        return voltage, internals


def controller_setup(build: ControllerBuild) -> ControllerSetup:
    """The ``ControllerSetup`` of a factory's inputs (no voltage limit given: none)."""
    design = build.design
    limit = build.voltage_limit or (math.inf,) * design.joints
    nominal = NominalDynamics(nominal_model(design.nominal))
    return ControllerSetup(design.sample_time, design.joints, tuple(limit), nominal)


def plugin_factory(cls: type[Controller]) -> Callable[[ControllerBuild], PluginSystem]:
    """The factory of a registered plug-in kind: ``cls(setup, **settings)`` with the
    fields of the scenario entry's settings dataclass as keyword arguments."""

    def build(inputs: ControllerBuild) -> PluginSystem:
        settings = {} if inputs.settings is None else dataclasses.asdict(inputs.settings)
        return PluginSystem(cls(controller_setup(inputs), **settings))

    return build


@dataclass(frozen=True, eq=False)
class UserPlugin:
    """A user's own controller class, loaded from a file or module by the scenario's
    ``!Python`` entry, with its ``settings`` and where it came from (``source``: the
    file or module; ``digest``: SHA-256 of the file's text, for provenance)."""

    cls: type[Controller]
    settings: Mapping[str, object]
    source: str
    digest: str
    label: str

    @property
    def kind(self) -> str:
        """The controller's name in tables, stores and ``--controller``: its class name."""
        return self.cls.__name__

    @property
    def spec(self) -> ControllerSpec:
        def build(inputs: ControllerBuild) -> PluginSystem:
            try:
                controller = self.cls(controller_setup(inputs), **dict(self.settings))
            except TypeError as error:
                raise PluginError(f"{self.kind} ({self.source}): {error}") from None
            return PluginSystem(controller)

        return ControllerSpec(kind=self.kind, label=self.label, factory=build)


def load_plugin(
    source_text: str, filename: str, class_name: str, settings: Mapping[str, object], label: str
) -> UserPlugin:
    """The ``Controller`` subclass ``class_name`` defined by Python ``source_text`` (the
    text of ``filename``, compiled under that name so tracebacks show the user's lines),
    executed in a fresh module."""
    digest = hashlib.sha256(source_text.encode()).hexdigest()
    name = f"posfb_plugin_{digest[:16]}"
    USER_SOURCES.add(filename)
    module = sys.modules.get(name)
    if module is None:
        module = types.ModuleType(name)
        module.__file__ = filename
        try:
            code = compile(source_text, filename, "exec")
        except SyntaxError as error:
            raise PluginError(f"{filename}: line {error.lineno}: {error.msg}") from None
        sys.modules[name] = module
        try:
            exec(code, module.__dict__)  # noqa: S102 - the user's own controller file
        except BaseException:
            del sys.modules[name]
            raise
    return UserPlugin(
        plugin_class(module, class_name, filename), dict(settings), filename, digest,
        label or class_name,
    )  # fmt: skip


def module_plugin(
    module_name: str, class_name: str, settings: Mapping[str, object], label: str
) -> UserPlugin:
    """The ``Controller`` subclass ``class_name`` of the importable module ``module_name``."""
    import importlib

    try:
        module = importlib.import_module(module_name)
    except ImportError as error:
        message = f"controller.module = {module_name!r} cannot be imported: {error}"
        raise PluginError(message) from None
    source = getattr(module, "__file__", None) or module_name
    USER_SOURCES.add(source)
    try:
        with open(source, "rb") as file:
            digest = hashlib.sha256(file.read()).hexdigest()
    except OSError:
        digest = ""
    cls = plugin_class(module, class_name, module_name)
    return UserPlugin(cls, dict(settings), module_name, digest, label or class_name)


def plugin_class(module: types.ModuleType, class_name: str, where: str) -> type[Controller]:
    """``module.class_name``, checked to be a ``posfb.Controller`` subclass."""
    cls = getattr(module, class_name, None)
    if cls is None:
        found = sorted(
            n for n, v in vars(module).items()
            if isinstance(v, type) and issubclass(v, Controller) and v is not Controller
        )  # fmt: skip
        hint = f"; it defines {', '.join(found)}" if found else ""
        raise PluginError(f"{where} has no class {class_name!r}{hint}")
    if not (isinstance(cls, type) and issubclass(cls, Controller)):
        raise PluginError(f"{where}: {class_name} is not a posfb.Controller subclass")
    return cls
