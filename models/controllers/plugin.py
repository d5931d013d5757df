"""Your own controller: the public contract (``posfb.Controller``) and the Drake system
that runs it in posfb's closed loop (``PluginSystem``).

A plug-in is a plain Python class; posfb wraps it in the same discrete system as its
built-in controllers (``models.controllers.base.SampledController``): both inputs held
by zero-order holds, direct feedthrough, so the voltage computed from the measurement
at ``t_k`` is applied on ``[t_k, t_k + T_s)``. The plug-in never gets a velocity: its
only measurement is the held, quantised joint position (position-only is structural,
``tests/models/controllers/test_controller_plugins.py`` checks it on the diagram).

The contract, in the order posfb calls it:

1. ``__init__(self, setup, **settings)``: ``setup`` is a ``ControllerSetup``
   (``sample_time``, ``joints``, ``voltage_limit`` and the scenario's ``nominal`` model;
   ``context`` is the loop context they are read from, ``models.design.loop_context``),
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

**Or a law.** A plug-in that sets ``self.law`` in ``__init__`` (a ``models.laws`` law,
``posfb.law(...)``, written on ``setup.nominal.symbolic()``) instead of writing ``start``
and ``step`` runs as the built-in controllers do (``base.LawController``), and gets what
they get: its linear feedback for ``design --margins``, the map and ``tune``
(``models.controllers.linearise``), ``posfb codegen`` and ``--sil``. ``memory_size`` is
then the law's; ``internals`` still names its internals.

**What tune may vary.** A plug-in written as a law may say which of its settings ``posfb
tune`` searches: ``tunable``, a class attribute mapping a keyword argument of
``__init__`` to its search box ``(low, high)``, ``0 < low < high`` (searched in log10).
The search starts from the scenario's value of the setting, else the ``__init__``
default; the tuned scenario holds the tuned values in its ``settings:`` map
(``plugin_tuning``).

Wrong sizes or non-finite output are refused in one line naming the class and its file
(``PluginError``). A ``ValueError`` raised inside the plug-in's own code (numpy's
"operands could not be broadcast", say) is one line too, naming the class and the file
and line of the plug-in where it was raised (``in_plugin``); any other exception
propagates as it is, with the plug-in's frames in its traceback.
"""

from __future__ import annotations

import dataclasses
import hashlib
import inspect
import json
import math
import sys
import traceback
import types
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, TypeVar

import numpy as np

from posfb.models.controllers.base import SampledController
from posfb.models.controllers.registry import ControllerBuild, ControllerSpec
from posfb.models.design.loop_context import InLoopContext, LoopContext
from posfb.models.lumped import LumpedModel
from posfb.models.nominal import LinearPart, nominal_model
from posfb.models.serial_model import SerialArmModel

if TYPE_CHECKING:
    from posfb.models.controllers.tunable import Tuning
    from posfb.models.laws.law import Law, Stepper
    from posfb.models.laws.nominal import SymbolicModel

_T = TypeVar("_T")

#: A registered plug-in class (``plugin_instance``).
_C = TypeVar("_C", bound="Controller")


class PluginError(ValueError):
    """A plug-in or its scenario entry is wrong (missing file, bad class, sizes,
    non-finite output, a ``ValueError`` in its code): one line that names its own keys."""


#: The source files of the user plug-ins loaded in this process: an error raised in
#: their code is shown with their frames only (``user_frames``).
USER_SOURCES: set[str] = set()


def user_frames(error: BaseException) -> list[traceback.FrameSummary]:
    """The frames of ``error``'s traceback that are in a user plug-in's source."""
    return [f for f in traceback.extract_tb(error.__traceback__) if f.filename in USER_SOURCES]


def in_plugin(name: str, call: Callable[[], _T]) -> _T:
    """``call()``, a call into the code of plug-in class ``name``; a ``ValueError``
    raised in the plug-in's source becomes a ``PluginError`` naming the class and the
    file and line where it was raised, so that it is one line that says where."""
    try:
        return call()
    except PluginError:
        raise
    except ValueError as error:
        frames = user_frames(error)
        if not frames:
            raise
        frame = frames[-1]
        where = f"{name} ({frame.filename}, line {frame.lineno})"
        raise PluginError(f"{where}: ValueError: {error}") from error


class NominalDynamics:
    """The scenario's nominal model as a plug-in sees it: joint ``i``'s equation of
    motion divided by its motor constant (``models.lumped``, reading note 9), so every
    "torque" is an armature voltage (V) and ``mass_matrix`` is in V s^2/rad.

    Eq. 2, ``M*(q) q'' + C*(q, q') q' + G*(q) + B* q' + F*(q') = u``, term by term:
    ``rigid_body`` (``M* q'' + C* q' + G*``), ``viscous_friction`` (``B* q'``) and
    ``coulomb_friction`` (``F*(q')``); ``inverse_dynamics`` is their sum, Coulomb
    friction included. A plug-in that models friction its own way composes the pieces
    it wants instead (``rigid_body(q, v, a) + viscous_friction(v)``, say)."""

    def __init__(self, model: LumpedModel | SerialArmModel | LinearPart) -> None:
        self._model = model

    def inverse_dynamics(self, q: np.ndarray, qdot: np.ndarray, qddot: np.ndarray) -> np.ndarray:
        """``M(q) qddot + C(q, qdot) qdot + G(q) + B qdot + F(qdot)`` (V, Eq. 2): the
        voltage that makes the nominal arm, Coulomb friction included, follow
        ``(q, qdot, qddot)``; the sum of ``rigid_body``, ``viscous_friction`` and
        ``coulomb_friction``."""
        rigid = self.rigid_body(q, qdot, qddot)
        return rigid + self.viscous_friction(qdot) + self.coulomb_friction(qdot)

    def rigid_body(self, q: np.ndarray, qdot: np.ndarray, qddot: np.ndarray) -> np.ndarray:
        """``M(q) qddot + C(q, qdot) qdot + G(q)`` (V): the arm's inertia, Coriolis,
        centrifugal and gravity terms of Eq. 2, no friction."""
        model = self._model
        q, qdot, qddot = (np.asarray(x, dtype=float) for x in (q, qdot, qddot))
        return np.asarray(model.M(q) @ qddot + model.coriolis(q, qdot) + model.G(q), dtype=float)

    def viscous_friction(self, qdot: np.ndarray) -> np.ndarray:
        """``B qdot`` (V): the viscous friction of Eq. 2 (``viscous()`` is ``B``)."""
        return self.viscous() @ np.asarray(qdot, dtype=float)

    def coulomb_friction(self, qdot: np.ndarray) -> np.ndarray:
        """``F(qdot) = diag(f_c) sgn(qdot)`` (V): the Coulomb friction of Eq. 2
        (reading note 1; ``coulomb_levels()`` is ``f_c``), 0 for a joint at rest."""
        return self.coulomb_levels() * np.sign(np.asarray(qdot, dtype=float))

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

    def symbolic(self) -> SymbolicModel:
        """The model as CasADi expressions (``models.laws.nominal``: ``ThetaModel`` for
        Table 1's form, ``UrdfModel`` for a URDF arm, ``LinearModel`` for the linear part
        a law's feedback is derived on), to write a step once as a law that the simulation
        evaluates and ``posfb codegen`` prints (the baselines PD + gravity and ADRC do)."""
        from posfb.models.laws.nominal import symbolic_of

        return symbolic_of(self._model)

    def mean_mass_matrix(self) -> np.ndarray:
        """``M0`` (n x n, V s^2/rad): the configuration-independent part of ``M(q)`` (Table
        1's closed form; for a URDF model, the mean over the joint angles), the inertia
        a fixed-gain tuning rule scales its gains by."""
        return np.asarray(self._model.M0(), dtype=float)


@dataclass(frozen=True)
class ControllerSetup(InLoopContext):
    """What a controller is designed for: the loop it runs in (``context``,
    ``models.design.loop_context``: its sample time ``T_s`` (s) and number of joints
    ``n`` read it), the voltage limit per joint (V) and the nominal model's dynamics."""

    context: LoopContext
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
    #: What ``posfb tune`` may vary: keyword argument of ``__init__`` -> ``(low, high)``
    #: (module docstring); empty: nothing.
    tunable: Mapping[str, tuple[float, float]] = {}

    def __init__(self, setup: ControllerSetup, **settings: object) -> None:
        if settings:
            raise PluginError(
                f"{type(self).__name__} takes no settings, got {', '.join(sorted(settings))}"
            )
        self.setup = setup

    def start(self, q: np.ndarray, desired: np.ndarray) -> np.ndarray:
        """The memory before the first sample (default: the law's start, else zeros)."""
        if getattr(self, "law", None) is not None:
            return self._law_stepper().start(q, desired)
        return np.zeros(self.memory_size)

    def step(
        self, q: np.ndarray, desired: np.ndarray, memory: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(voltage, internals)`` at this sample; updates ``memory`` in place (default:
        the law's step)."""
        if getattr(self, "law", None) is not None:
            return self._law_stepper().step(q, desired, memory)
        raise NotImplementedError(f"{type(self).__name__}.step is not written")

    def _law_stepper(self) -> Stepper:
        """The numeric evaluation of ``self.law``, made on first use."""
        from posfb.models.laws.law import Stepper

        stepper = self.__dict__.get("_stepper")
        if stepper is None or stepper.law is not self.law:
            stepper = self.__dict__["_stepper"] = Stepper(self.law)
        return stepper


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
        self._name = type(controller).__name__
        self.set_name(f"{type(controller).__name__}_controller")

    @property
    def internals_columns(self) -> tuple[str, ...]:
        return self.internals_names

    def _start(self, q: np.ndarray, desired: np.ndarray) -> np.ndarray:
        started = in_plugin(self._name, lambda: self.plugin.start(q.copy(), desired.copy()))
        memory = np.array(started, dtype=float).ravel()
        if memory.shape != (self.memory_size,):
            raise PluginError(
                f"{self._where}: start returned {memory.shape[0]} memory values; "
                f"memory_size = {self.memory_size} is required"
            )
        return memory

    def _step(
        self, q: np.ndarray, desired: np.ndarray, memory: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        result = in_plugin(self._name, lambda: self.plugin.step(q.copy(), desired.copy(), memory))
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
    """The ``ControllerSetup`` of a factory's inputs (no voltage limit given: none; the
    nominal model's linear part where the build asks for it)."""
    design = build.design
    limit = build.voltage_limit or (math.inf,) * design.joints
    model = nominal_model(design.nominal)
    nominal = NominalDynamics(LinearPart(model) if build.linear_part else model)
    return ControllerSetup(design.context, tuple(limit), nominal)


def plugin_law(controller: Controller) -> Law | None:
    """The law a plug-in instance is written as (``self.law``), checked; ``None`` for one
    written as ``start`` and ``step``."""
    from posfb.models.laws.law import Law

    law = getattr(controller, "law", None)
    if law is None:
        return None
    where = plugin_where(controller)
    if not isinstance(law, Law):
        raise PluginError(f"{where}: law = {law!r}; a posfb.law(...) is required")
    if law.joints != controller.setup.joints:
        raise PluginError(f"{where}: its law has {law.joints} joints; the arm has "
                          f"{controller.setup.joints}")  # fmt: skip
    return law


def plugin_system(controller: Controller) -> SampledController:
    """A plug-in instance's Drake system: the ``LawController`` of its law, or the
    ``PluginSystem`` that calls its ``start`` and ``step``."""
    from posfb.models.controllers.base import LawController

    law = plugin_law(controller)
    if law is None:
        return PluginSystem(controller)
    where = plugin_where(controller)
    names = _names(controller.internals, where)
    if len(names) != law.internals:
        raise PluginError(f"{where}: internals names {len(names)} columns; its law has "
                          f"{law.internals}")  # fmt: skip
    return LawController(law, controller.setup.sample_time, names)


def written_law(controller: Controller, kind: str) -> Law:
    """``plugin_law``, or ``PluginError`` for a plug-in written as a step."""
    law = plugin_law(controller)
    if law is None:
        raise PluginError(
            f"controller {kind!r} is written as a step (no law): posfb cannot linearise it or "
            "print it as C; set self.law = posfb.law(...) in its __init__ for the margins, "
            "tuning and posfb codegen"
        )
    return law


def plugin_factory(cls: type[Controller]) -> Callable[[ControllerBuild], SampledController]:
    """The factory of a registered plug-in kind: ``cls(setup, **settings)`` with the
    fields of the scenario entry's settings dataclass as keyword arguments."""

    def build(inputs: ControllerBuild) -> SampledController:
        return plugin_system(plugin_instance(cls, inputs))

    return build


def plugin_instance(cls: type[_C], build: ControllerBuild) -> _C:
    """``cls(setup, **settings)`` of a registered plug-in kind (``plugin_factory``'s, before
    it is wrapped in a Drake system)."""
    settings = {} if build.settings is None else dataclasses.asdict(build.settings)
    return cls(controller_setup(build), **settings)


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

    def instance(self, inputs: ControllerBuild) -> Controller:
        """The class made for ``inputs`` with the scenario's settings."""
        where = f"{self.kind} ({self.source})"
        setup = controller_setup(inputs)
        try:
            return in_plugin(self.kind, lambda: self.cls(setup, **dict(self.settings)))
        except TypeError as error:
            raise PluginError(f"{where}: {error}") from None

    @property
    def spec(self) -> ControllerSpec:
        return ControllerSpec(
            kind=self.kind,
            label=self.label,
            factory=lambda inputs: plugin_system(self.instance(inputs)),
            law=lambda inputs: written_law(self.instance(inputs), self.kind),
            tuning=plugin_tuning(self.cls) if self.cls.tunable else None,
        )


def _defaults(cls: type[Controller]) -> dict[str, object]:
    """The keyword arguments of ``cls.__init__`` with their defaults."""
    parameters = inspect.signature(cls.__init__).parameters
    return {name: p.default for name, p in parameters.items() if p.kind is p.KEYWORD_ONLY
            or p.kind is p.POSITIONAL_OR_KEYWORD}  # fmt: skip


def check_tunable(cls: type[Controller], where: str) -> None:
    """Refuse a ``tunable`` that names no keyword argument of ``__init__`` or whose box is
    not ``0 < low < high`` (one line naming the class and the setting)."""
    tunable = cls.tunable
    if not isinstance(tunable, Mapping):
        raise PluginError(f"{where}: {cls.__name__}.tunable = {tunable!r}; a map of setting "
                          "names to (low, high) is required")  # fmt: skip
    accepted = _defaults(cls)
    for name, box in tunable.items():
        if name not in accepted or name in ("self", "setup"):
            raise PluginError(f"{where}: {cls.__name__}.tunable names {name!r}, which is no "
                              "keyword argument of its __init__")  # fmt: skip
        low, high = box if isinstance(box, Sequence) and len(box) == 2 else (None, None)
        numbers = all(isinstance(v, int | float) and math.isfinite(v) for v in (low, high))
        if not (numbers and 0 < low < high):
            raise PluginError(f"{where}: {cls.__name__}.tunable[{name!r}] = {box!r}; a search "
                              "box (low, high) with 0 < low < high is required")  # fmt: skip


def plugin_tuning(cls: type[Controller]) -> Tuning:
    """What tune may vary of plug-in ``cls`` (its ``tunable``): one knob per setting, from
    the entry's value (a ``!Python`` entry's ``settings``, JSON text) or the ``__init__``
    default; ``apply`` writes the values into the entry's ``settings``."""
    from posfb.models.controllers.tunable import Knob, Tuning

    defaults = _defaults(cls)

    def value(entry: object, name: str) -> object:
        given = json.loads(entry.settings)
        if name in given:
            return given[name]
        if defaults[name] is inspect.Parameter.empty:
            raise ValueError(f"controller.settings.{name}: {cls.__name__}.tunable names it "
                             "and it has no default; a value is required")  # fmt: skip
        return defaults[name]

    def knobs(entry: object) -> tuple[Knob, ...]:
        found = []
        for name, (low, high) in cls.tunable.items():
            start = value(entry, name)
            if not (isinstance(start, int | float) and start > 0):
                raise ValueError(f"controller.settings.{name} = {start!r}; tune searches it "
                                 "in log10: a number > 0 is required")  # fmt: skip
            found.append(Knob(name, float(low), float(high), float(start)))
        return tuple(found)

    def apply(entry: object, values: np.ndarray, sample_time: float) -> object:
        tuned = dict(zip(cls.tunable, (float(v) for v in values), strict=True))
        return dataclasses.replace(entry, settings=json.dumps(json.loads(entry.settings) | tuned))

    return Tuning(knobs=knobs, apply=apply, shown=tuple(cls.tunable), value=value)


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
    check_tunable(cls, where)
    return cls
