"""The robot as data: pydantic models of ``hardware/*.yaml``.

A robot description lists the modules front to rear, the PICO boards on the
RS485 bus with their motors and sensors, each motor's control modes with its
raw range and raw<->SI conversion, hard limits with a clip-or-refuse policy,
geometry, and the clamp and motion parameters the simulator and the protective
layer use. Adding a sensor, a motor, a board or a whole module is an edit of
this file, not of code.

Higher layers never ask for "board 22": they ask for roles -
:meth:`RobotDescription.bend_modules` of a half, :meth:`RobotDescription.joint_motor`
of a module, :meth:`RobotDescription.rotate_motor` - and the description answers
from the file.

Validation is two steps. pydantic checks the shape and each field's bounds;
:meth:`RobotDescription.cross_check` then checks the rules that span the file
(unique board ids, every referenced module exists, each half has its bend pair,
limits inside raw ranges) and returns each problem with its path, so the loader
can point at ``file:line:column``.
"""

from __future__ import annotations

import copy
import hashlib
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, fields
from types import MappingProxyType
from typing import Any

from pydantic import (
    Field,
    PrivateAttr,
    ValidationInfo,
    model_validator,
)

from pirate_bt.robot.channels import ChannelSpec, SetpointSlot
from pirate_bt.robot.configs import (
    Band,
    BridgeConfig,
    ClampConfig,
    ContactPoint,
    MotionConfig,
    SafetyConfig,
)
from pirate_bt.robot.fitness import Workable, motor_limit_problems, workable_problems
from pirate_bt.robot.parts import (
    AccelerationMax,
    AngleRange,
    AngleSensor,
    AngularVelocityMax,
    Board,
    ControlMode,
    Conversion,
    CurrentConversion,
    Feedback,
    Half,
    ImuSensor,
    LimitPolicy,
    ModeTable,
    Module,
    Motor,
    MotorFunction,
    MotorLimits,
    Name,
    PositionConversion,
    PwmConversion,
    RawRange,
    Role,
    Sensor,
    SensorKind,
    SpringSensor,
    Title,
    TorqueConversion,
    TorqueMax,
    VelocityConversion,
    VelocityMax,
    _Model,
)
from pirate_bt.units import SchemaVersion

__all__ = [
    "AccelerationMax",
    "AngleRange",
    "AngleSensor",
    "AngularVelocityMax",
    "Band",
    "Board",
    "BridgeConfig",
    "ChannelSpec",
    "ClampConfig",
    "ContactPoint",
    "ControlMode",
    "Conversion",
    "CurrentConversion",
    "Feedback",
    "Half",
    "ImuSensor",
    "LimitPolicy",
    "ModeTable",
    "Module",
    "MotionConfig",
    "Motor",
    "MotorFunction",
    "MotorLimits",
    "Name",
    "PositionConversion",
    "PwmConversion",
    "RawRange",
    "RobotDescription",
    "Role",
    "SafetyConfig",
    "Sensor",
    "SensorKind",
    "SetpointSlot",
    "SpringSensor",
    "TorqueConversion",
    "TorqueMax",
    "VelocityConversion",
    "VelocityMax",
]


KeyPath = tuple[str | int, ...]
Problem = tuple[KeyPath, str] | tuple[KeyPath, str, KeyPath]
"""A cross-check's problem: where, what, and for a duplicate where the first is."""


def _in_words(path: KeyPath, message: str, first: KeyPath | None = None) -> str:
    """A problem with no file to point into: a duplicate's first place as a path."""
    if first is None:
        return message
    where = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in first)
    return f"{message} (first at {where.lstrip('.')})"


def _unknown(kind: str, name: object, known: Iterable[object]) -> KeyError:
    """A lookup's miss, naming what the robot has."""
    have = ", ".join(str(k) for k in known) or "none"
    return KeyError(f"the robot has no {kind} {name!r} (it has: {have})")


class RobotDescription(_Model):
    """A whole robot: modules front to rear, boards, and parameters."""

    schema_version: SchemaVersion = 1
    """version of this file format"""
    name: Title
    """the robot's name"""
    description: str = ""
    """free text"""
    assumptions: list[str] = Field(
        default_factory=list, description="values in this file that are not public, and why"
    )
    templates: dict[str, Any] = Field(
        default_factory=dict, description="free space for YAML anchors; ignored"
    )
    modules: list[Module] = Field(min_length=3)
    """modules front to rear"""
    boards: list[Board] = Field(min_length=1, max_length=254)
    """PICO boards on the RS485 bus (ids 1 to 254, each once)"""
    clamp: ClampConfig
    motion: MotionConfig
    bridge: BridgeConfig
    safety: SafetyConfig = SafetyConfig()

    _index: _Index = PrivateAttr()

    @property
    def _ix(self) -> _Index:
        # The index, read straight from pydantic's private-attribute store: plain
        # ``self._index`` goes through BaseModel.__getattr__ (about 1 µs), and the
        # lookups below run every tick. Unset (cross-checks deferred): the same
        # AttributeError as ``self._index``.
        private = self.__pydantic_private__
        if private is not None and "_index" in private:
            index: _Index = private["_index"]
            return index
        return self._index

    @model_validator(mode="after")
    def _cross(self, info: ValidationInfo) -> RobotDescription:
        context = info.context if isinstance(info.context, dict) else {}
        problems = self.cross_check()
        if problems and not context.get("defer_cross_checks"):
            # no file to point into: a duplicate names its first place by its path
            raise ValueError("; ".join(_in_words(*problem) for problem in problems))
        if not problems:
            self._index = _Index.build(self)
        return self

    # -- cross-field rules ------------------------------------------------

    def cross_check(self) -> list[Problem]:
        """Rules that span the file, each as ``(path, message)``, or, for a duplicate,
        ``(path, message, path of the first)``; empty when valid."""
        out: list[Problem] = []
        modules = {m.name: i for i, m in enumerate(self.modules)}
        seen_mod: dict[str, int] = {}
        for i, mod in enumerate(self.modules):
            if mod.name in seen_mod:
                out.append(
                    (
                        ("modules", i, "name"),
                        f"duplicate module name {mod.name!r}",
                        ("modules", seen_mod[mod.name], "name"),
                    )
                )
            seen_mod.setdefault(mod.name, i)
            if mod.role is Role.ROTATIONAL and mod.half is not None:
                out.append((("modules", i, "half"), "the rotational module belongs to no half"))
            if mod.role is not Role.ROTATIONAL and mod.half is None:
                out.append((("modules", i, "half"), f"module {mod.name!r} needs a half"))
        roles = [m.role for m in self.modules]
        if roles[0] is not Role.FRONT:
            out.append((("modules", 0, "role"), "the first module must have role 'front'"))
        if roles[-1] is not Role.REAR:
            out.append(
                (("modules", len(roles) - 1, "role"), "the last module must have role 'rear'")
            )
        rot = [i for i, r in enumerate(roles) if r is Role.ROTATIONAL]
        if len(rot) != 1:
            out.append((("modules",), f"need exactly one rotational module, found {len(rot)}"))
        else:
            for i, mod in enumerate(self.modules):
                want = Half.FRONT if i < rot[0] else Half.REAR if i > rot[0] else None
                if want is not None and mod.half not in (None, want):
                    out.append(
                        (("modules", i, "half"), f"module {mod.name!r} lies in the {want} half")
                    )

        ids: dict[int, int] = {}
        names: dict[str, tuple[str | int, ...]] = {}
        for b, board in enumerate(self.boards):
            if board.id in ids:
                out.append(
                    (
                        ("boards", b, "id"),
                        f"duplicate board id {board.id}",
                        ("boards", ids[board.id], "id"),
                    )
                )
            ids.setdefault(board.id, b)
            if board.module not in modules:
                out.append(
                    (("boards", b, "module"), f"board {board.id}: unknown module {board.module!r}")
                )
            for kind, items in (("motors", board.motors), ("sensors", board.sensors)):
                slots: set[int] = set()
                for j, item in enumerate(items):
                    path: tuple[str | int, ...] = ("boards", b, kind, j)
                    if item.slot in slots:
                        out.append(
                            (
                                (*path, "slot"),
                                f"board {board.id}: {kind[:-1]} slot {item.slot} used twice",
                            )
                        )
                    slots.add(item.slot)
                    if item.name in names:
                        out.append(
                            (
                                (*path, "name"),
                                f"duplicate name {item.name!r}",
                                (*names[item.name], "name"),
                            )
                        )
                    names.setdefault(item.name, path)
            for j, motor in enumerate(board.motors):
                out.extend(motor_limit_problems(motor, ("boards", b, "motors", j)))

        by_module: dict[str, list[Board]] = {}
        for board in self.boards:
            by_module.setdefault(board.module, []).append(board)

        def has(module: str, function: MotorFunction | None, sensor: SensorKind | None) -> bool:
            bs = by_module.get(module, [])
            if function is not None and not any(
                m.function is function for x in bs for m in x.motors
            ):
                return False
            return sensor is None or any(s.kind is sensor for x in bs for s in x.sensors)

        for half in Half:
            bends = [m for m in self.modules if m.role is Role.BEND and m.half is half]
            if len(bends) < 2 or len(bends) % 2:
                out.append(
                    (
                        ("modules",),
                        f"the {half} half needs its bend pair (an even number >= 2 of bend"
                        f" modules), found {len(bends)}",
                    )
                )
        for i, mod in enumerate(self.modules):
            if mod.role is Role.BEND and not has(mod.name, MotorFunction.BEND, SensorKind.ANGLE):
                out.append(
                    (
                        ("modules", i, "name"),
                        f"bend module {mod.name!r} needs a board with a bend motor"
                        " and an angle sensor",
                    )
                )
            if mod.role is Role.ROTATIONAL and not has(
                mod.name, MotorFunction.ROTATE, SensorKind.ANGLE
            ):
                out.append(
                    (
                        ("modules", i, "name"),
                        f"rotational module {mod.name!r} needs a board with a rotate"
                        " motor and an angle sensor",
                    )
                )
        pts = self.clamp.contact_angles
        for k in range(1, len(pts)):
            if pts[k].diameter <= pts[k - 1].diameter:
                out.append(
                    (
                        ("clamp", "contact_angles", k, "diameter"),
                        "contact_angles must be sorted by increasing diameter",
                    )
                )
        # a run's needs: fresh state, sensors that read what they are read for
        parts = Workable(
            self.modules, self.boards, self.clamp, self.bridge, self.safety, self.motion
        )
        out.extend(workable_problems(parts))
        return out

    # -- role-based queries (higher layers use these, never board ids) -----

    def module(self, name: str) -> Module:
        """The module called ``name``.

        Raises:
            KeyError: no such module (its message names the robot's modules).
        """
        try:
            return self._ix.modules[name]
        except KeyError:
            raise _unknown("module", name, self._ix.modules) from None

    def bend_modules(self, half: Half) -> list[Module]:
        """The bend modules of a half, front to rear."""
        private = self.__pydantic_private__  # the index, as _ix reads it (every tick)
        if private is not None and "_index" in private:
            return list(private["_index"].bend.get(half, ()))
        return [m for m in self.modules if m.role is Role.BEND and m.half is half]

    def behind_front_tip_m(self) -> dict[str, float]:
        """How far each module's middle is behind the robot's front tip (metres), by
        module name, front to rear: where the simulator puts a module, and where the
        task layer looks for it (the IMU on the rotational module, a bend joint)."""
        out: dict[str, float] = {}
        behind = 0.0
        for module in self.modules:
            out[module.name] = behind + module.length / 2
            behind += module.length
        return out

    def all_bend_modules(self) -> list[Module]:
        return [m for m in self.modules if m.role is Role.BEND]

    def rotational_module(self) -> Module:
        return next(m for m in self.modules if m.role is Role.ROTATIONAL)

    def motors(self) -> Iterator[tuple[Board, Motor]]:
        for board in self.boards:
            for motor in board.motors:
                yield board, motor

    def sensors(self) -> Iterator[tuple[Board, AngleSensor | SpringSensor | ImuSensor]]:
        for board in self.boards:
            for sensor in board.sensors:
                yield board, sensor

    def motor(self, name: str) -> Motor:
        """The motor called ``name`` (``KeyError`` naming the robot's motors if none)."""
        try:
            return self._ix.motors[name][1]
        except KeyError:
            raise _unknown("motor", name, self._ix.motors) from None

    def board(self, board_id: int) -> Board:
        """The board with bus id ``board_id`` (``KeyError`` if none)."""
        for board in self.boards:
            if board.id == board_id:
                return board
        raise _unknown("board with id", board_id, [b.id for b in self.boards])

    def board_of(self, name: str) -> Board:
        """The board that carries motor or sensor ``name``."""
        if name in self._ix.motors:
            return self._ix.motors[name][0]
        try:
            return self._ix.sensors[name][0]
        except KeyError:
            known = [*self._ix.motors, *self._ix.sensors]
            raise _unknown("motor or sensor", name, known) from None

    def motor_of(self, module: str, function: MotorFunction) -> Motor:
        """The motor with ``function`` on ``module``'s boards (``KeyError`` if none)."""
        found = self._ix.by_function.get((module, function))
        if found is None:
            raise KeyError(f"module {module!r} has no {function} motor")
        return found

    def sensor_of(self, module: str, kind: SensorKind) -> AngleSensor | SpringSensor | ImuSensor:
        """The sensor of ``kind`` on ``module``'s boards (``KeyError`` if none)."""
        found = self._ix.by_kind.get((module, kind))
        if found is None:
            raise KeyError(f"module {module!r} has no {kind} sensor")
        return found

    def joint_motor(self, module: str) -> Motor:
        return self.motor_of(module, MotorFunction.BEND)

    def rotate_motor(self) -> Motor:
        return self.motor_of(self.rotational_module().name, MotorFunction.ROTATE)

    def drive_motors(self) -> list[Motor]:
        """The drive motors, in the order of :meth:`motors` (boards as listed)."""
        return list(self._ix.drives)

    def imu(self) -> ImuSensor | None:
        for _, s in self.sensors():
            if isinstance(s, ImuSensor):
                return s
        return None

    def module_of(self, name: str) -> Module:
        """The module that carries motor or sensor ``name``."""
        return self.module(self.board_of(name).module)

    # -- wire layout --------------------------------------------------------

    def state_channels(self) -> list[ChannelSpec]:
        """The state frame's int16 channels in wire order (boards by id, sensors, feedback)."""
        return list(self._ix.channels)

    def channel_periods_s(self) -> Mapping[str, float]:
        """How often each state channel is fresh, by name: its sensor's period, or the
        bridge's state period where none is given. Read-only and shared: a
        caller checking many channels each tick looks them up here."""
        return self._ix.periods

    def setpoint_slots(self) -> list[SetpointSlot]:
        """The bulk setpoint frame's motors in wire order (boards by id, then slot)."""
        return list(self._ix.setpoints)

    def board_ids(self) -> list[int]:
        return sorted(b.id for b in self.boards)

    def layout_digest(self) -> int:
        """A 32-bit digest of the wire layout; both ends compare it at hello time.

        Covers the channel order and, per motor, its stop role, modes and raw ranges
        (docs/protocol.md, Layout; ``pirate_bt.link.layout.layout_text`` spells it out).
        """
        text = ";".join(f"{c.board}:{c.name}" for c in self._ix.channels)
        motors = []
        for s in self._ix.setpoints:
            f = s.motor.function
            role = (
                f.value
                if f in (MotorFunction.DRIVE, MotorFunction.ROTATE, MotorFunction.BEND)
                else "other"
            )
            modes = ",".join(
                f"{mode.value}={c.raw[0]}..{c.raw[1]}"
                for mode in ControlMode
                if (c := s.motor.modes.get(mode)) is not None
            )
            motors.append(f"{s.board}:{s.slot}:{role}:{modes}")
        text += "|" + ";".join(motors)
        return int.from_bytes(hashlib.sha256(text.encode()).digest()[:4], "big")

    def digest(self) -> str:
        """SHA-256 of the whole description, for traces and reports."""
        return hashlib.sha256(self.model_dump_json().encode()).hexdigest()


_READ_ONLY = ("periods", "bend")


@dataclass
class _Index:
    modules: dict[str, Module]
    motors: dict[str, tuple[Board, Motor]]
    sensors: dict[str, tuple[Board, AngleSensor | SpringSensor | ImuSensor]]
    by_function: dict[tuple[str, MotorFunction], Motor]
    by_kind: dict[tuple[str, SensorKind], AngleSensor | SpringSensor | ImuSensor]
    channels: Sequence[ChannelSpec]
    setpoints: Sequence[SetpointSlot]
    drives: tuple[Motor, ...]
    periods: Mapping[str, float]
    bend: Mapping[Half, tuple[Module, ...]]

    # A read-only mapping (``periods``, ``bend``) neither pickles nor deep-copies: the
    # index goes as plain dicts and is read back read-only, so a description goes to a
    # process pool's worker (``executor.submit(simulate_tree, ..., robot=robot)``) and
    # is deep-copied whole (until 2026-11-30 both raised "cannot pickle 'mappingproxy'").
    def _plain(self) -> dict[str, Any]:
        return {
            f.name: dict(value) if isinstance(value, MappingProxyType) else value
            for f in fields(self)
            for value in (getattr(self, f.name),)
        }

    @classmethod
    def _from_plain(cls, plain: dict[str, Any]) -> _Index:
        read_only: dict[str, Any] = {k: MappingProxyType(plain[k]) for k in _READ_ONLY}
        return cls(**{**plain, **read_only})

    def __reduce__(self) -> tuple[Any, ...]:
        return (_Index._from_plain, (self._plain(),))

    def __deepcopy__(self, memo: dict[int, Any]) -> _Index:
        return _Index._from_plain(copy.deepcopy(self._plain(), memo))

    @classmethod
    def build(cls, desc: RobotDescription) -> _Index:
        motors: dict[str, tuple[Board, Motor]] = {}
        sensors: dict[str, tuple[Board, AngleSensor | SpringSensor | ImuSensor]] = {}
        by_function: dict[tuple[str, MotorFunction], Motor] = {}
        by_kind: dict[tuple[str, SensorKind], AngleSensor | SpringSensor | ImuSensor] = {}
        channels: list[ChannelSpec] = []
        setpoints: list[SetpointSlot] = []
        for board in sorted(desc.boards, key=lambda b: b.id):
            for sensor in sorted(board.sensors, key=lambda s: s.slot):
                sensors[sensor.name] = (board, sensor)
                by_kind.setdefault((board.module, sensor.kind), sensor)
                dim = "force" if sensor.kind is SensorKind.SPRING else "angle"
                for name in sensor.channel_names():
                    channels.append(
                        ChannelSpec(
                            len(channels), board.id, name, sensor.conversion(), dim, sensor.period
                        )
                    )
            for motor in sorted(board.motors, key=lambda m: m.slot):
                motors[motor.name] = (board, motor)
                by_function.setdefault((board.module, motor.function), motor)
                setpoints.append(SetpointSlot(len(setpoints), board.id, motor.slot, motor))
                for key, dim in (("velocity", "velocity"), ("current", "current")):
                    conv = getattr(motor.feedback, key)
                    if conv is not None:
                        channels.append(
                            ChannelSpec(
                                len(channels),
                                board.id,
                                f"{motor.name}.{key}",
                                conv,
                                dim,
                                desc.bridge.state_period,
                            )
                        )
        return cls(
            modules={m.name: m for m in desc.modules},
            motors=motors,
            sensors=sensors,
            by_function=by_function,
            by_kind=by_kind,
            channels=tuple(channels),
            setpoints=tuple(setpoints),
            drives=tuple(m for _, m in desc.motors() if m.function is MotorFunction.DRIVE),
            periods=MappingProxyType(
                {c.name: c.period_s or desc.bridge.state_period for c in channels}
            ),
            bend=MappingProxyType(
                {
                    half: tuple(m for m in desc.modules if m.role is Role.BEND and m.half is half)
                    for half in Half
                }
            ),
        )
