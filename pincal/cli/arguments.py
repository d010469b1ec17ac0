"""Command-line options shared by several ``pincal`` commands, spelled once so they cannot drift.

The calibration options are made from :class:`~pincal.calibration.options.CalibrationOptions`
(:func:`add_calibration_options`, :func:`given_options`): their flags, choices and help are the dataclass's.
"""

from __future__ import annotations

import argparse
import math
import re
from collections.abc import Collection, Mapping
from typing import TYPE_CHECKING, Any

from pincal.calibration.options import OPTIONS, PARAMETERS_HELP
from pincal.errors import DataError, OutputError, PincalError

if TYPE_CHECKING:
    from pincal.identification.corrections import Payload

#: ``--meshes`` choices, the default first: pincal.io.mesh_files.MESH_MODES, spelled here so that parsing imports no
#: NumPy (tests/cli/test_export.py holds them equal).
MESH_MODES = ("keep", "copy")
MEASURE_HELP = "position, pose, or keys such as distance:A-B, distance_increment:A-B, joint:NAME"


def _whole(text: str) -> int:
    """``text`` as a whole number; else an argparse error naming it (not argparse's 'invalid positive_int value')."""
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a whole number") from None


def _number(text: str) -> float:
    """``text`` as a number; else an argparse error naming it."""
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None


def positive_int(text: str) -> int:
    """An argparse type: a whole number ≥ 1 (argparse turns the error into a one-line usage message)."""
    value = _whole(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"{value} is not a positive whole number")
    return value


def non_negative_int(text: str) -> int:
    """An argparse type: a whole number ≥ 0 (counts, random seeds)."""
    value = _whole(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"{value} is negative; a whole number ≥ 0 is needed")
    return value


def positive_float(text: str) -> float:
    """An argparse type: a finite number > 0 (a standard deviation used as a weight [m, rad])."""
    value = _number(text)
    if not 0.0 < value < float("inf"):
        raise argparse.ArgumentTypeError(f"{text} is not a finite number > 0")
    return value


def non_negative_float(text: str) -> float:
    """An argparse type: a finite number ≥ 0 (a noise or error size [m, rad]; 0 for none)."""
    value = _number(text)
    if not 0.0 <= value < float("inf"):
        raise argparse.ArgumentTypeError(f"{text} is not a finite number ≥ 0")
    return value


def parameter_shift(text: str) -> tuple[str, float]:
    """An argparse type: ``NAME=VALUE``, a parameter's name and a finite change [m, rad]."""
    name, sep, value = text.partition("=")
    try:
        number = float(value)
    except ValueError:
        number = float("nan")
    if not sep or not name.strip() or not abs(number) < float("inf"):
        raise argparse.ArgumentTypeError(f"'{text}' is not NAME=VALUE with a finite VALUE [m, rad] "
                                         "(e.g. arm_1_joint.offset=0.002)")
    return name.strip(), number


def add_robot(parser: argparse.ArgumentParser, note: str = "") -> None:
    """The positional ROBOT: a URDF path or a known robot name."""
    parser.add_argument("robot", help="URDF file or known robot name" + (f" ({note})" if note else ""))


def add_meshes(parser: argparse.ArgumentParser, written: str) -> None:
    """``--meshes keep|copy``: what the mesh file names of a written URDF become (pincal.io.mesh_files)."""
    parser.add_argument("--meshes", choices=MESH_MODES, default=MESH_MODES[0],
                        help=f"mesh files of {written}: keep (default: package:// names as in the robot's URDF, "
                             "relative ones rewritten relative to the written file) or copy (every mesh copied "
                             "beside it into <name>_meshes/, named by relative paths); never an absolute path")


def add_measurement(parser: argparse.ArgumentParser) -> None:
    """``--measure`` and ``--frame``."""
    parser.add_argument("--measure", nargs="+", default=["position"], help=MEASURE_HELP)
    parser.add_argument("--frame", help="measured frame for position/pose (default: a frame named like an end "
                                        "effector, else the one link the actuated joints move with none moving below "
                                        "it, else the link every loop closes on (a platform); refused when that is "
                                        "not one link)")


def add_perturb(parser: argparse.ArgumentParser) -> None:
    """``--perturb``: σ of the simulated true errors [m and rad]."""
    parser.add_argument("--perturb", type=non_negative_float, default=1e-3,
                        help="σ of the true errors [m and rad] (default 1e-3)")


def add_spread(parser: argparse.ArgumentParser) -> None:
    """``--spread``: half-range of the random actuated values about the reference [rad or m]."""
    parser.add_argument("--spread", type=positive_float, metavar="S",
                        help="draw each actuated joint within ±S of the reference configuration [rad for revolute, "
                             "m for prismatic joints], within its URDF limits (default: anywhere within the URDF "
                             "limits, except five_bar, hexapod, hexapod_device, ucr3, whose limits exceed their "
                             "workspace; a joint without limits: ±0.5 rad on closed-loop robots, ±π on serial ones)")


def add_parameters(parser: argparse.ArgumentParser, help_text: str = PARAMETERS_HELP) -> None:
    """``--parameters``: a named set or shell-style name patterns."""
    parser.add_argument("--parameters", nargs="+", help=help_text)


def payload(text: str) -> Payload:
    """An argparse type: ``MASS@FRAME`` or ``MASS@FRAME:X,Y,Z``, a point mass [kg] on a frame at an offset [m] in it."""
    from pincal.identification.corrections import Payload

    mass, _, place = text.partition("@")
    frame, _, offset = place.rpartition(":") if "," in place.rpartition(":")[2] else (place, "", "")
    try:
        values = tuple(float(v) for v in offset.split(",")) if offset else (0.0, 0.0, 0.0)
        if len(values) != 3 or "@" not in text:
            raise ValueError(offset)
        return Payload(float(mass), frame, (values[0], values[1], values[2]))
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not MASS@FRAME or MASS@FRAME:X,Y,Z (kg; m in the frame), e.g. "
                                         "1.5@tool0 or 1.5@tool0:0,0,0.1") from None
    except DataError as exc:
        raise argparse.ArgumentTypeError(f"'{text}': {exc}") from None


def add_payload(parser: argparse.ArgumentParser, note: str) -> None:
    """``--payload MASS@FRAME[:X,Y,Z]``: a point mass the robot carries, for the joint compliances."""
    parser.add_argument("--payload", type=payload, metavar="MASS@FRAME[:X,Y,Z]",
                        help="a point mass the robot carries: MASS [kg] on FRAME (a link or frame of the URDF), at "
                             "X,Y,Z [m] in that frame (default 0,0,0); its gravity torque adds to the links' in the "
                             f"joint compliances ('*.compliance'), and is refused without one; {note}")


def factor_or_off(text: str) -> float | str:
    """An argparse type: a finite factor > 0, or ``off``."""
    if text.strip().lower() == "off":
        return "off"
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not 0.0 < value < math.inf:
        raise argparse.ArgumentTypeError(f"'{text}' is not a factor > 0 or 'off'")
    return value


def prior_factor(text: str) -> float | str:
    """An argparse type: a finite factor > 0, ``auto`` or ``off``."""
    if text.strip().lower() == "auto":
        return "auto"
    try:
        return factor_or_off(text)
    except argparse.ArgumentTypeError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a factor > 0, 'auto' or 'off'") from None


def sigmas(text: str) -> float | tuple[float, ...]:
    """An argparse type: one σ > 0 [m, rad], or one per residual row written ``a,b,c``."""
    values = tuple(positive_float(word) for word in text.split(","))
    return values[0] if len(values) == 1 else values


#: The argparse type of each kind of calibration option (:attr:`~pincal.calibration.options.Option.kind`).
_TYPES: dict[str, Any] = {"int": positive_int, "seed": non_negative_int, "sigma": positive_float, "sigmas": sigmas,
                          "payload": payload,
                          "factor": factor_or_off, "prior": prior_factor}


def add_calibration_options(parser: argparse.ArgumentParser, skip: Collection[str] = ()) -> None:
    """Every option of :class:`~pincal.calibration.options.CalibrationOptions` the command line gives (all but
    ``skip`` and the library-only ones), as its metadata spells it. None of them has an argparse default: an option
    not given is None here, so that a job file's value (or the dataclass's default) stands."""
    for name, option in OPTIONS.items():
        if option.api_only or name in skip:
            continue
        how: dict[str, Any] = {"dest": name, "help": option.help, "default": None}
        if option.kind == "texts":
            how["nargs"] = "+"
        elif option.kind == "flag":  # given: True; not given: None, so that the default stands
            how["action"] = "store_true"
        elif option.kind in _TYPES:
            how["type"] = _TYPES[option.kind]
        if option.choices is not None:
            how["choices"] = list(option.choices)
        if option.metavar is not None:
            how["metavar"] = option.metavar
        parser.add_argument(option.flag, **how)


#: An option as the library writes it in a message: its keyword and value (``cv_seed=5``, ``cv='loo'``,
#: ``frame=NAME``); the keyword is a word, the value a quoted text or a run of characters up to a space or , ; : )
_KEYWORD = re.compile(r"\b([a-z][a-z0-9_]*)=('[^']*'|\"[^\"]*\"|[^\s,;:)]+)")


QUOTES = ("'", '"')


def in_flags(message: str, flags: Mapping[str, str] | None = None) -> str:
    """A library message in the command line's words: each option it writes as a keyword and value
    (``select='bic'``, ``cv_seed=5``, ``frame=NAME``) written as its flag and value (``--select bic``,
    ``--cv-seed 5``, ``--frame NAME``), a switch given as True as its flag alone (``register=True``: ``--register``).

    Args:
        message: The library's message.
        flags: The command's own options, keyword to flag (:func:`command_flags`), beside the calibration options.

    Returns:
        The message with each keyword the command or the calibration options know written as its flag.
    """
    known = {name: option.flag for name, option in OPTIONS.items()} | dict(flags or {})

    def flag(match: re.Match[str]) -> str:
        name, value = match.group(1), match.group(2)
        if name not in known:
            return match.group(0)
        if value[:1] in QUOTES:
            value = value[1:-1]
        return known[name] if value == "True" else f"{known[name]} {value}"  # a switch: register=True, --register

    return _KEYWORD.sub(flag, message)


#: The library keywords that name outputs in :class:`~pincal.errors.OutputError` messages (:func:`output_in_flags`),
#: each with the command-line option it is (:func:`calibrate_files`' ``out_urdf`` and ``report_path`` are
#: ``calibrate``'s ``--out`` and ``--report``).
OUTPUT_KEYWORDS = {"out": "out", "out_urdf": "out", "report_path": "report", "images": "images"}


def output_in_flags(message: str, option: str | None, flags: Mapping[str, str]) -> str:
    """An output's error in the command line's words: each library keyword of :data:`OUTPUT_KEYWORDS` that labels an
    output in it (``out 'cal.urdf' is the input file …``, ``images: …``, ``… the same file as out_urdf '…'``)
    written as the command's flag (``--out 'cal.urdf' …``), the paths left quoted. ``option``: the error's; a message
    with none is left as it is, as is a keyword the command has no flag for."""
    if option is None:
        return message
    names = {k: flags[v] for k, v in OUTPUT_KEYWORDS.items() if v in flags}
    if not names:
        return message
    label = "|".join(re.escape(k) for k in sorted(names, key=len, reverse=True))
    return re.sub(rf"(?<![\w=-])({label})(?=:| '| \(its)", lambda m: names[m.group(1)], message)


def error_in_flags(error: PincalError, flags: Mapping[str, str]) -> str:
    """A library error's message as the command line shows it: each option it names by its keyword written as the
    command's flag (:func:`in_flags`; an output's label too, :func:`output_in_flags`), unless it names its file (a job
    file's errors name the file's own keys)."""
    if error.file is not None:
        return str(error)
    shown = in_flags(str(error), flags)
    return output_in_flags(shown, error.option, flags) if isinstance(error, OutputError) else shown


def command_flags(parser: argparse.ArgumentParser, func: Any) -> dict[str, str]:
    """The options of the (sub)command whose ``func`` default is ``func``, keyword (argparse dest) to its long flag:
    how the command line spells an option a library error names by keyword. Empty when no subcommand has it."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                if sub.get_default("func") is func:
                    return {a.dest: max(a.option_strings, key=len) for a in sub._actions
                            if a.option_strings and a.dest != "help"}
                found = command_flags(sub, func)
                if found:
                    return found
    return {}


def given_options(args: argparse.Namespace) -> dict[str, Any]:
    """The calibration options given on the command line (those not given left out), by keyword."""
    return {name: getattr(args, name) for name in OPTIONS if getattr(args, name, None) is not None}


class _Unbuilt:
    """The parser of a subcommand the command line does not run, not built: whatever is asked of it (an argument, a
    group, defaults, a subcommand), it answers with itself."""

    def __getattr__(self, name: str) -> _Unbuilt:
        return self

    def __call__(self, *args: Any, **kwargs: Any) -> _Unbuilt:
        return self


class Subcommands(argparse._SubParsersAction):  # type: ignore[type-arg]
    """argparse's subcommands, which build the parser of ``only`` alone when it is set: the twenty others' parsers
    (their arguments, their help) are a tenth of a command's start that its run never reads."""

    only: str | None = None

    def add_parser(self, name: str, **kwargs: Any) -> argparse.ArgumentParser:
        """argparse's ``add_parser``; for a command other than :attr:`only`, a stand-in that builds nothing."""
        if self.only is not None and name != self.only:
            return _Unbuilt()  # type: ignore[return-value]  # answers every call register() makes on a parser
        return super().add_parser(name, **kwargs)  # type: ignore[no-any-return]
