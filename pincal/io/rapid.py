"""ABB RAPID modules read for ``pincal filter`` (docs/filter_rapid.md).

Targets are the points of ``MoveL``, ``MoveJ``, ``MoveC`` (two), their ``DO``/``AO``/``GO``/``Sync`` forms and
``TriggL``/``TriggJ``/``TriggC``: a ``robtarget`` declared once with a value (``CONST``, ``PERS`` or ``VAR``) or written
in the move, ``[[x, y, z], [q1, q2, q3, q4], [cf1, cf4, cf6, cfx], [eax_a, …]]`` (millimetres; a unit quaternion
``q1`` = w); ``MoveAbsJ``'s ``jointtarget`` ``[[j1, …, j6], [eax…]]`` (degrees) are joint targets. A point is the TCP of
the move's ``tooldata`` (``tool0``: the flange; ``[robhold, [[x, y, z], [q1…q4]], load]``) in its work object
(``\\WObj:=``, default ``wobj0``: the world frame, :func:`moc_base` placing the robot in it; ``[robhold, ufprog,
ufmec, uframe, oframe]``, the point in ``uframe · oframe``). A tool the robot does not hold, a moving work object, an
array, ``*`` or an expression (``Offs(…)``, ``RelTool(…)``) in a point's place, a search are problems, left as
written. The configuration ``cf1, cf4, cf6, cfx`` is read for the filter to check and rewrite
(:mod:`pincal.calibration.arm_posture`); the external axes are kept.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable

import numpy as np
import pinocchio as pin

from pincal.errors import DataError, listing
from pincal.io.programs import (
    Edit,
    NamedPosture,
    Problem,
    Program,
    Target,
    closing,
    comment_free,
    joint_render,
    line_of,
    number_text,
    numbers,
    split_top,
    stripped,
)

#: Decimals written: millimetres and quaternion components.
MM_DECIMALS, QUATERNION_DECIMALS, DEGREE_DECIMALS = 4, 9, 6
#: Moves and how many points they take first.
MOVES = {**{f"{m}{s}": 2 if m.endswith("C") else 1 for m in ("MoveL", "MoveJ", "MoveC")
            for s in ("", "DO", "AO", "GO", "Sync")}, "TriggL": 1, "TriggJ": 1, "TriggC": 2, "MoveAbsJ": 1}
_MOVE = re.compile(r"\b(" + "|".join(sorted(MOVES, key=len, reverse=True)) + r"|Search[LC]\w*)\b", re.IGNORECASE)
_DECL = re.compile(r"\b(CONST|PERS|VAR)\s+(robtarget|jointtarget|tooldata|wobjdata)\s+(\w+)\s*(\{[^}]*\})?\s*:=\s*",
                   re.IGNORECASE)
_WOBJ = re.compile(r"\\WObj\s*:=\s*(\w+)", re.IGNORECASE)
#: An assignment to a data object or a part of it (``pB.trans.z := …``, ``tGlue := …``), at a statement's start: a
#: point, tool or work object changed so is not what its declaration says where the moves read it.
_CHANGE = re.compile(r"(?:^|;)[ \t]*([A-Za-z_]\w*)[ \t]*(?:\.[ \t]*\w+[ \t]*|\{[^}\n]*\}[ \t]*)*:=", re.MULTILINE)
_WORD = re.compile(r"[A-Za-z_]\w*")

Spans = list[tuple[float, int, int]]


def _groups(text: str, start: int, end: int) -> list[tuple[int, int]] | None:
    """The spans of the top-level items of the aggregate ``[…]`` that is exactly ``text[start:end]``, or None."""
    a, b = stripped(text, (start, end))
    if a >= b or text[a] != "[" or closing(text, a) != b - 1:
        return None
    return [stripped(text, span) for span in split_top(text, a + 1, b - 1)]


def _numbers_of(text: str, span: tuple[int, int], count: int) -> Spans | None:
    a, b = span
    if b - a < 2 or text[a] != "[" or closing(text, a) != b - 1:
        return None
    found = numbers(text, a + 1, b - 1)
    return found if found is not None and len(found) == count else None


def _placement(text: str, span: tuple[int, int]) -> tuple[pin.SE3, Spans, Spans] | None:
    """``[[x, y, z], [q1, q2, q3, q4]]`` [mm, unit quaternion w first] in SI units, with the numbers' spans."""
    groups = _groups(text, *span)
    return _pose(text, groups) if groups is not None and len(groups) >= 2 else None


def _pose(text: str, groups: list[tuple[int, int]]) -> tuple[pin.SE3, Spans, Spans] | None:
    position, quaternion = _numbers_of(text, groups[0], 3), _numbers_of(text, groups[1], 4)
    if position is None or quaternion is None:
        return None
    w, x, y, z = (v for v, _, _ in quaternion)
    norm = math.sqrt(w * w + x * x + y * y + z * z)
    if not 0.99 < norm < 1.01:
        return None
    rotation = pin.Quaternion(w / norm, x / norm, y / norm, z / norm).matrix()
    return pin.SE3(rotation, np.array([v for v, _, _ in position]) / 1e3), position, quaternion


def _render(file: str, position: Spans, quaternion: Spans) -> Callable[[pin.SE3], list[Edit]]:
    old = np.array([v for v, _, _ in quaternion])

    def render(pose: pin.SE3) -> list[Edit]:
        q = pin.Quaternion(pose.rotation)
        new = np.array([q.w, q.x, q.y, q.z])
        new = -new if new @ old < 0 else new
        edits = [Edit(file, s, e, number_text(v * 1e3, MM_DECIMALS))
                 for v, (_, s, e) in zip(pose.translation.tolist(), position, strict=True)]
        return edits + [Edit(file, s, e, number_text(v, QUATERNION_DECIMALS))
                        for v, (_, s, e) in zip(new.tolist(), quaternion, strict=True)]
    return render


def _posture(file: str, text: str, groups: list[tuple[int, int]]) -> NamedPosture | None:
    """The configuration ``[cf1, cf4, cf6, cfx]`` a robtarget writes; None when it is not four whole numbers."""
    found = _numbers_of(text, groups[2], 4) if len(groups) > 2 else None
    if found is None or any(v != int(v) for v, _, _ in found):
        return None
    return NamedPosture("rapid", file, {name: (int(v), a, b) for name, (v, a, b) in
                                        zip(("cf1", "cf4", "cf6", "cfx"), found, strict=True)})


def _frames(code: str, kinds: dict[str, tuple[str, int, tuple[int, int], str]]) -> dict[str, pin.SE3 | str]:
    """Tools and work objects by name (lower case): their frame, or why it is not read."""
    frames: dict[str, pin.SE3 | str] = {"tool0": pin.SE3.Identity(), "wobj0": pin.SE3.Identity()}
    for name, (kind, line, span, _) in kinds.items():
        groups = _groups(code, *span)
        if kind == "tooldata":
            if groups is None or len(groups) < 2 or code[slice(*groups[0])].upper() not in ("TRUE", "FALSE"):
                frames[name] = f"tooldata '{name}' (line {line}) is not read"
            elif code[slice(*groups[0])].upper() != "TRUE":
                frames[name] = f"tooldata '{name}' (line {line}) is a stationary tool (robhold FALSE)"
            else:
                found = _placement(code, groups[1])
                frames[name] = found[0] if found else f"tooldata '{name}' (line {line}): its tframe is not read"
        elif kind == "wobjdata":
            if groups is None or len(groups) < 5:
                frames[name] = f"wobjdata '{name}' (line {line}) is not read"
            elif [code[slice(*g)].upper() for g in groups[:3]] != ["FALSE", "TRUE", '""']:
                frames[name] = (f"wobjdata '{name}' (line {line}) is held by the robot or moved by a mechanical unit "
                                "(robhold, ufprog, ufmec not FALSE, TRUE, \"\")")
            else:
                user, obj = _placement(code, groups[3]), _placement(code, groups[4])
                frames[name] = (user[0] * obj[0] if user and obj else
                                f"wobjdata '{name}' (line {line}): its uframe or oframe is not read")
    return frames


_MOC = re.compile(r"-base_frame_(pos_[xyz]|orient_u[0-3])[ \t]+([+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)")


def moc_base(extra: dict[str, str]) -> tuple[pin.SE3, str] | None:
    """The robot's base frame in the world frame: the ``-base_frame_pos_x … _z`` [m] and ``-base_frame_orient_u0 …
    u3`` (a unit quaternion, ``u0`` = w) of the controller's ``MOC.cfg`` among the further files (an attribute not
    written takes ABB's default: 0, ``u0`` 1; none written, the world frame), with where, in words; None when no file
    is given.

    Raises:
        DataError: a file not a MOC.cfg; an attribute written twice (several robots' base frames), or not a unit
            quaternion.
    """
    values: dict[str, tuple[float, str]] = {}
    places: dict[str, tuple[str, int]] = {}  # where -> (file, line), for the errors' fields
    for name, text in extra.items():
        if not text.lstrip().startswith("MOC:"):
            raise DataError(f"config file '{name}' is not a MOC.cfg (its first line 'MOC:CFG_…'): for a RAPID program "
                            "pincal reads the robot's base frame from the controller's MOC.cfg", file=name,
                            option="config")
        for match in _MOC.finditer(text):
            line = line_of(text, match.start())
            where = f"{name} line {line}"
            places[where] = (name, line)
            key = match.group(1)
            if key in values:
                raise DataError(f"-base_frame_{key} is written twice ({values[key][1]}, {where}): several robots' "
                                "base frames; give a MOC.cfg of this robot, or the robot's base", file=name, line=line)
            values[key] = (float(match.group(2)), where)
    if not values:  # ABB's files leave out attributes at their default: the base frame is the world frame
        return (pin.SE3.Identity(), f"ABB's default, the world frame ({listing(list(extra))} writes no "
                                    "-base_frame_ attribute)") if extra else None
    value = {k: v for k, (v, _) in values.items()}
    position = np.array([value.get(f"pos_{c}", 0.0) for c in "xyz"])
    w, x, y, z = (value.get(f"orient_u{k}", 1.0 if k == 0 else 0.0) for k in range(4))
    norm = math.sqrt(w * w + x * x + y * y + z * z)
    first = min(values.values(), key=lambda v: v[1])[1]
    if not 0.99 < norm < 1.01:
        raise DataError(f"the base frame of {first}: -base_frame_orient_u0 … u3 is not a unit quaternion",
                        file=places[first][0], line=places[first][1])
    rotation = pin.Quaternion(w / norm, x / norm, y / norm, z / norm).matrix()
    return pin.SE3(rotation, position), f"the base frame of {first}"


def read_rapid(text: str, file: str, tcp: pin.SE3) -> Program:
    """The targets of a RAPID module (module docstring); ``tcp`` is not used (a RAPID move names its tool) and kept for
    the readers' common signature."""
    del tcp
    program = Program("rapid", {file: text})
    code = comment_free(text, "!")
    kinds: dict[str, tuple[str, int, tuple[int, int], str]] = {}
    seen: dict[str, int] = {}
    for match in _DECL.finditer(code):
        name, line = match.group(3).lower(), line_of(text, match.start())
        seen[name] = seen.get(name, 0) + 1
        end = closing(code, match.end()) if code.startswith("[", match.end()) else -1
        if match.group(4) or end < 0:
            program.problems.append(Problem(file, line, f"{match.group(2)} '{match.group(3)}': "
                                                        f"{'an array' if match.group(4) else 'its value'} is not read"))
            continue
        kinds[name] = (match.group(2).lower(), line, (match.end(), end + 1), match.group(3))
    frames = _frames(code, kinds)
    changed = _changes(text, code, kinds, frames)
    uses: dict[str, list[tuple[int, str, str]]] = {}
    joints: set[str] = set()
    unquoted = re.sub(r'"[^"\n]*"', lambda m: '"' + " " * (len(m.group(0)) - 2) + '"', code)
    for match in _MOVE.finditer(unquoted):  # a string's text (TPWrite "MoveL …") is no move
        line, keyword = line_of(text, match.start()), match.group(1)
        end = code.find(";", match.end())
        if keyword.lower().startswith("search"):
            program.problems.append(Problem(file, line, f"{keyword}: a search, left as written"))
            continue
        if end < 0:
            program.problems.append(Problem(file, line, f"{keyword}: no ';' ends it"))
            continue
        fields = [stripped(code, s) for s in split_top(code, match.end(), end)]
        fields = [f for f in fields if not code.startswith("\\", f[0])]
        wobj = _WOBJ.search(code, match.end(), end)
        words = [_WORD.match(code, a) for a, _ in fields]
        tool = next((w.group(0).lower() for w in words[1:] if w and w.group(0).lower() in frames
                     and not w.group(0).lower().startswith("wobj") and kinds.get(w.group(0).lower(), ("tooldata",))[0]
                     == "tooldata"), None)
        count = MOVES[next(m for m in MOVES if m.lower() == keyword.lower())]
        for a, b in fields[:count]:
            point = code[a:b].split("\\")[0].strip()
            b = a + len(code[a:b].split("\\")[0].rstrip())
            if keyword.lower() == "moveabsj":
                _joint(program, file, code, (a, b), point, line, kinds, joints)
                continue
            context = (tool or "", wobj.group(1).lower() if wobj else "wobj0")
            if not tool:
                program.problems.append(Problem(file, line, f"{keyword}: its tool is not found among the module's "
                                                            "tooldata: left as written"))
                continue
            if _WORD.fullmatch(point):
                uses.setdefault(point.lower(), []).append((line, *context))
                continue
            groups = _groups(code, a, b)
            if groups is None or len(groups) < 2:
                shown = point if len(point) <= 30 else point[:27] + "..."
                program.problems.append(Problem(file, line, f"{keyword}: point '{shown}' is neither a robtarget "
                                                            "nor its value: left as written"))
                continue
            _add(program, file, line, keyword, code, groups, context, frames, (line,))
    for name, where in uses.items():
        lines = tuple(line for line, _, _ in where)
        kind = kinds.get(name, ("", 0, (0, 0), name))
        if name in changed:
            shown = f"line{'s' if len(lines) > 1 else ''} {', '.join(map(str, lines))}"
            program.problems.append(Problem(file, changed[name], f"point '{kind[3]}' is changed by the program here "
                                                                 f"(its moves: {shown}): left as written"))
            continue
        if kind[0] != "robtarget" or seen.get(name, 0) != 1:
            why = ("declared more than once" if seen.get(name, 0) > 1 else "not a robtarget declared with a value")
            program.problems.append(Problem(file, lines[0], f"point '{kind[3]}': {why}: left as written"))
            continue
        if len({(t, w) for _, t, w in where}) > 1:
            program.problems.append(Problem(file, kind[1], f"'{kind[3]}' is reached with several tools or work objects "
                                                           f"(lines {', '.join(map(str, lines))}): left as written"))
            continue
        groups = _groups(code, *kind[2])
        if groups is None or len(groups) < 2:
            program.problems.append(Problem(file, kind[1], f"robtarget '{name}': its value is not read"))
            continue
        _add(program, file, kind[1], kind[3], code, groups, (where[0][1], where[0][2]), frames, lines)
    for name, (kind_name, line, _, _) in kinds.items():
        if kind_name in ("robtarget", "jointtarget") and name not in uses and name not in joints:
            program.problems.append(Problem(file, line, f"{kind_name} '{name}' is read by no move pincal reads: left "
                                                        "as written"))
    program.targets.sort(key=lambda t: t.uses[0] if t.uses else t.line)
    return program


def _changes(text: str, code: str, kinds: dict[str, tuple[str, int, tuple[int, int], str]],
             frames: dict[str, pin.SE3 | str]) -> dict[str, int]:
    """The data objects the program assigns (:data:`_CHANGE`), by name (lower case), with the line of the first; each
    tool and work object among them made, in ``frames``, the reason its points are left as written."""
    changed: dict[str, int] = {}
    for match in _CHANGE.finditer(code):
        changed.setdefault(match.group(1).lower(), line_of(text, match.start(1)))
    for name, at in changed.items():
        if kinds.get(name, ("",))[0] in ("tooldata", "wobjdata"):
            frames[name] = f"'{kinds[name][3]}' is changed by the program at line {at}"
    return changed


def _joint(program: Program, file: str, code: str, span: tuple[int, int], point: str, line: int,
           kinds: dict[str, tuple[str, int, tuple[int, int], str]], joints: set[str]) -> None:
    """A ``MoveAbsJ`` point: a jointtarget's name or value [°]."""
    name = point.lower()
    if _WORD.fullmatch(point):
        joints.add(name)
        if kinds.get(name, ("",))[0] != "jointtarget":
            program.problems.append(Problem(file, line, f"MoveAbsJ: '{point}' is not a jointtarget declared with a "
                                                        "value"))
            return
        line_at, span = kinds[name][1], kinds[name][2]
        point = kinds[name][3]
    else:
        line_at = line
    groups = _groups(code, *span)
    found = _numbers_of(code, groups[0], 6) if groups else None
    if found is None:
        program.problems.append(Problem(file, line_at, f"MoveAbsJ: '{point[:30]}' is not a jointtarget of six axes"))
        return
    program.targets.append(Target(file, line_at, point, np.radians([v for v, _, _ in found]), None,
                                  pin.SE3.Identity(), pin.SE3.Identity(), "joints", None, (line,),
                                  render_joints=joint_render(file, [(a, b) for _, a, b in found], 180 / math.pi,
                                                             DEGREE_DECIMALS)))


def _add(program: Program, file: str, line: int, name: str, code: str, groups: list[tuple[int, int]],
         context: tuple[str, str], frames: dict[str, pin.SE3 | str], uses: tuple[int, ...]) -> None:
    if len(groups) != 4:
        program.problems.append(Problem(file, line, f"'{name}': a robtarget has 4 parts ([x, y, z], [q1, q2, q3, q4], "
                                                    f"[cf1, cf4, cf6, cfx], [eax_a, …]), this one {len(groups)}: left "
                                                    "as written"))
        return
    found = _pose(code, groups)
    if found is None:
        program.problems.append(Problem(file, line, f"'{name}': its position or unit quaternion is not read"))
        return
    tool, wobj = (frames.get(n, f"'{n}' is not declared in the module") for n in context)
    for frame in (tool, wobj):
        if isinstance(frame, str):
            program.problems.append(Problem(file, line, f"'{name}': {frame}: left as written"))
            return
    assert isinstance(tool, pin.SE3) and isinstance(wobj, pin.SE3)
    pose, position, quaternion = found
    program.targets.append(Target(file, line, name, None, pose, tool, wobj, f"tool {context[0]}, work object "
                                  f"{context[1]}", _render(file, position, quaternion), uses,
                                  _posture(file, code, groups)))
