"""A robot program read by its language's reader (:func:`read_program`, for ``pincal filter``, docs/filter.md): the
file's suffix chooses :mod:`pincal.io.urscript`, :mod:`pincal.io.krl` or :mod:`pincal.io.rapid`, which build on the
types and text helpers of :mod:`pincal.io.programs`; the robot's base is taken from a controller's file or given.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

import pinocchio as pin

from pincal.errors import DataError
from pincal.io.krl import read_krl, robroot
from pincal.io.programs import Program, language_of, lines_of, read_text
from pincal.io.rapid import moc_base, read_rapid
from pincal.io.urscript import read_urscript


def dat_of(path: str | Path) -> Path | None:
    """A KRL program's ``.dat``: the file beside the ``.src`` with its stem and the suffix ``.dat`` or ``.DAT``
    (KUKA's controllers write both cases); None when there is none."""
    for suffix in (".dat", ".DAT", ".Dat"):
        dat = Path(path).with_suffix(suffix)
        if dat.is_file():
            return dat
    return None


def read_program(path: str | Path, tcp: pin.SE3, config: Sequence[str | Path] = (),
                 robot_base: pin.SE3 | None = None) -> Program:
    """The program at ``path`` read by its language's reader (:func:`language_of`); ``tcp`` is the tool centre point
    [m, rad] in the flange frame where the program sets none; ``config``: further files of the controller (KRL: the
    ``TOOL_DATA``, ``BASE_DATA`` of ``$config.dat`` and the ``$ROBROOT`` of ``$machine.dat``; RAPID: the robot's base
    frame in ``MOC.cfg``); ``robot_base``: the robot's base frame in the program's world frame [m, rad], where no file
    gives it. The targets' frames are then in the robot's base frame; :attr:`Program.robot_base` says what was taken.

    Raises:
        DataError: an unknown suffix; a file missing or unreadable (a KRL ``.src`` without its ``.dat`` is read
            alone, its problems saying what it lacks); the robot's base given twice, or to a URScript program (whose
            poses are in the robot's base frame).
    """
    language = language_of(path)
    originals: dict[str, str] = {str(path): read_text(path)}
    text = lines_of(originals[str(path)])
    extra = {str(p): lines_of(read_text(p, "config file")) for p in config}
    if language == "urscript":
        if robot_base is not None or extra:
            raise DataError(f"PROGRAM '{path}' is URScript, whose poses are in the robot's base frame: a config file "
                            "and a robot base are for KRL and RAPID", file=str(path),
                            option="robot_base" if robot_base is not None else "config")
        program = read_urscript(text, str(path), tcp)
        program.texts = originals  # every byte as read: line ends kept
        return program
    if language == "krl":
        world, words = _robot_base(robroot(extra), robot_base, "$WORLD", "--config $machine.dat")
        dat = dat_of(path)
        if dat is not None:
            originals[str(dat)] = read_text(dat, "the program's .dat")
        dat_text = lines_of(originals[str(dat)]) if dat is not None else None
        program = read_krl(text, str(path), dat_text, str(dat or Path(path).with_suffix(".dat")), extra, tcp, world)
    else:
        world, words = _robot_base(moc_base(extra), robot_base, "the world frame", "--config MOC.cfg")
        program = read_rapid(text, str(path), tcp)
    program.robot_base = words
    program.texts = {name: originals[name] for name in program.texts}  # every byte as read: line ends kept
    if world is not None:
        inverse = world.inverse()
        program.targets = [t if t.pose is None else replace(t, frame=inverse * t.frame) for t in program.targets]
    return program


def _robot_base(found: tuple[pin.SE3, str] | None, given: pin.SE3 | None, world: str,
                option: str) -> tuple[pin.SE3 | None, str]:
    """The robot's base in the program's world frame, from a controller's file or ``--robot-base``, and in words."""
    if found is not None and given is not None:
        raise DataError(f"the robot's base is given twice: {found[1]} and robot_base=X,Y,Z,RX,RY,RZ; give one",
                        option="robot_base")
    if found is not None:
        return found[0], f"robot base in {world}: {found[1]}"
    if given is not None:
        return given, f"robot base in {world}: --robot-base"
    return None, f"{world} taken as the robot's base (none given: {option} or --robot-base)"
