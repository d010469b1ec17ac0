"""Universal Robots URScript programs read for ``pincal filter`` (docs/filter_urscript.md).

Targets are the first argument of ``movej``, ``movel``, ``movep`` and ``servoj`` and the two of ``movec``: a pose
literal ``p[x, y, z, rx, ry, rz]`` (metres; a rotation vector [rad]) in the robot's base frame, a joint list
``[q1, …, q6]`` [rad], or a variable assigned one of them once (``global Waypoint_1_p=p[…]``, Polyscope's layout);
and the pose of ``get_inverse_kin(pose, qnear=q)`` (Polyscope's MoveJ), its ``qnear`` [rad] where the controller's
inverse kinematics starts. The tool centre point is the last ``set_tcp(p[…])`` above the move, else the one the caller
gives. Anything else in a target's place (``pose_trans(…)``, a variable assigned twice or never) and a ``set_tcp`` of
anything but a literal are problems, left as written; a pose or joint variable no move reads too.
"""

from __future__ import annotations

import re
from collections.abc import Callable

import numpy as np
import pinocchio as pin

from pincal.io.programs import (
    Edit,
    Problem,
    Program,
    Target,
    closing,
    joint_render,
    line_of,
    number_text,
    numbers,
    rotation_vector_near,
    split_top,
    stripped,
)
from pincal.records import record

#: The moves read, and how many of their first arguments are targets.
MOVES = {"movej": 1, "movel": 1, "movep": 1, "servoj": 1, "movec": 2}
#: Decimals written: metres and radians (1e-8 m, 1e-8 rad).
DECIMALS = 8

_CALL = re.compile(r"\b(movej|movel|movep|servoj|movec|set_tcp)\s*\(")
_ASSIGN = re.compile(r"^[ \t]*(?:global[ \t]+|local[ \t]+)?([A-Za-z_]\w*)[ \t]*=[ \t]*(?=(?:p[ \t]*)?\[)", re.MULTILINE)
#: Any assignment to a variable or an element of it (``x = …``, ``x[2] = …``; not ``==``): a target variable assigned
#: anything besides its literal goes where the program puts it, not where the literal says.
_ANY_ASSIGN = re.compile(r"^[ \t]*(?:global[ \t]+|local[ \t]+)?([A-Za-z_]\w*)[ \t]*(?:\[[^\]\n]*\][ \t]*)?=(?!=)",
                         re.MULTILINE)
#: A pose literal's opening: ``p[``, white space allowed between (URScript reads ``p [`` as ``p[``).
_POSE = re.compile(r"p[ \t]*(?=\[)")
_NAME = re.compile(r"[A-Za-z_]\w*")
#: Polyscope's MoveJ waypoint: ``movej(get_inverse_kin(Waypoint_1_p, qnear=Waypoint_1_q), …)``.
_INVERSE = re.compile(r"get_inverse_kin[ \t]*\(")


def code_mask(text: str) -> np.ndarray:
    """(len(text),) True where the character is code: not in a ``#`` comment nor a string."""
    mask = np.ones(len(text), dtype=bool)
    k = 0
    while k < len(text):
        c = text[k]
        if c == "#":
            end = text.find("\n", k)
            end = len(text) if end < 0 else end
            mask[k:end] = False
            k = end
        elif c in "\"'":
            end = text.find(c, k + 1)
            end = len(text) if end < 0 else end + 1
            mask[k:end] = False
            k = end
        else:
            k += 1
    return mask


@record(frozen=True)
class _Literal:
    """A pose or joint literal: its values and the numbers' spans."""

    pose: bool
    values: list[float]
    spans: list[tuple[int, int]]


def _literal(text: str, start: int, end: int) -> _Literal | None:
    """The literal ``p[…]`` or ``[…]`` that is exactly ``text[start:end]``, or None."""
    a, b = stripped(text, (start, end))
    prefix = _POSE.match(text, a, b)
    pose = prefix is not None
    opening = prefix.end() if prefix else a
    if opening >= b or text[opening] != "[" or closing(text, opening) != b - 1:
        return None
    found = numbers(text, opening + 1, b - 1)
    if found is None or len(found) != 6:
        return None
    return _Literal(pose, [v for v, _, _ in found], [(s, e) for _, s, e in found])


def _pose(values: list[float]) -> pin.SE3:
    return pin.SE3(pin.exp3(np.array(values[3:])), np.array(values[:3]))


def _render(file: str, literal: _Literal) -> Callable[[pin.SE3], list[Edit]]:
    def render(pose: pin.SE3) -> list[Edit]:
        rotation = rotation_vector_near(pose.rotation, literal.values[3:])
        new = [*pose.translation.tolist(), *rotation.tolist()]
        return [Edit(file, s, e, number_text(v, DECIMALS)) for v, (s, e) in zip(new, literal.spans, strict=True)]
    return render


def _assignments(text: str, mask: np.ndarray) -> dict[str, list[tuple[int, _Literal | None]]]:
    """Each variable's assignments in code (``mask``): where its value starts, and the literal assigned (None: anything
    else)."""
    assigned: dict[str, list[tuple[int, _Literal | None]]] = {}
    for match in _ASSIGN.finditer(text):
        if not mask[match.start(1)]:
            continue
        start = match.end()
        prefix = _POSE.match(text, start)
        opening = prefix.end() if prefix else start
        close = closing(text, opening)
        literal = _literal(text, start, close + 1) if close > 0 else None
        assigned.setdefault(match.group(1), []).append((start, literal))
    literal_at = {start for where in assigned.values() for start, _ in where}
    for match in _ANY_ASSIGN.finditer(text):
        start = match.end()
        while start < len(text) and text[start] in " \t":
            start += 1
        if mask[match.start(1)] and start not in literal_at:
            assigned.setdefault(match.group(1), []).append((start, None))
    return assigned


def read_urscript(text: str, file: str, tcp: pin.SE3) -> Program:
    """The targets of a URScript program (module docstring); ``tcp`` is the tool centre point in the flange frame
    until a ``set_tcp`` sets one."""
    program = Program("urscript", {file: text})
    mask = code_mask(text)
    assigned = _assignments(text, mask)
    tool: pin.SE3 | None = tcp
    tool_line = 0
    used: dict[str, list[tuple[int, pin.SE3 | None, int]]] = {}
    nears: dict[str, np.ndarray] = {}  # a variable target's qnear, from its first move
    hints: set[str] = set()  # the variables read as qnear
    for match in _CALL.finditer(text):
        if not mask[match.start()]:
            continue
        name, opening = match.group(1), match.end() - 1
        line = line_of(text, match.start())
        close = closing(text, opening)
        if close < 0:
            program.problems.append(Problem(file, line, f"{name}(: its parenthesis is not closed"))
            continue
        arguments = split_top(text, opening + 1, close)
        if name == "set_tcp":
            literal = _literal(text, *arguments[0])
            if literal is None or not literal.pose:
                program.problems.append(Problem(file, line, "set_tcp of something other than a pose literal p[…]: "
                                                            "the moves below it are left as written"))
                tool, tool_line = None, line
            else:
                tool, tool_line = _pose(literal.values), line
            continue
        for span in arguments[:MOVES[name]]:
            a, b = stripped(text, span)
            near = None
            inverse = _INVERSE.match(text, a, b)
            if inverse is not None and closing(text, inverse.end() - 1) == b - 1:
                inner = split_top(text, inverse.end(), b - 1)
                near, why = _qnear(text, inner[1:], assigned, hints)
                if why is not None:
                    program.problems.append(Problem(file, line, f"{name}: get_inverse_kin: {why}: left as written"))
                    continue
                a, b = stripped(text, inner[0])
            word = text[a:b]
            literal = _literal(text, a, b)
            if _NAME.fullmatch(word) and word not in ("p",):
                used.setdefault(word, []).append((line, tool, tool_line))
                if near is not None:
                    nears.setdefault(word, near)
                continue
            if literal is None:
                shown = word if len(word) <= 40 else word[:37] + "..."
                program.problems.append(Problem(file, line, f"{name}: target '{shown}' is neither a literal p[…] or "
                                                            "[…] of six numbers nor a variable assigned one"))
                continue
            _add(program, file, line, name, literal, tool, tool_line, (line,), near)
    for variable, uses in used.items():
        lines = tuple(line for line, _, _ in uses)
        where = assigned.get(variable, [])
        if len(where) != 1 or where[0][1] is None:
            why = ("never assigned a literal" if not where else
                   f"assigned {len(where)} times" if len(where) > 1 else "assigned something other than a literal")
            program.problems.append(Problem(file, lines[0], f"target '{variable}': {why}; the moves that read it go "
                                                            "where the program puts them"))
            continue
        tools = {id(t) for _, t, _ in uses}
        line_at = line_of(text, where[0][0])
        literal = where[0][1]
        if literal.pose and len(tools) > 1:
            program.problems.append(Problem(file, line_at, f"'{variable}' is read with {len(tools)} different TCPs "
                                                           f"(lines {', '.join(map(str, lines))}): left as written"))
            continue
        _add(program, file, line_at, variable, literal, uses[0][1], uses[0][2], lines, nears.get(variable))
    for variable, where in assigned.items():
        if variable not in used and variable not in hints and any(lit is not None for _, lit in where):
            program.problems.append(Problem(file, line_of(text, where[0][0]), f"'{variable}' is assigned a pose or "
                                                                              "joint literal no move reads: left as "
                                                                              "written"))
    program.targets.sort(key=lambda t: t.uses[0] if t.uses else t.line)
    return program


def _qnear(text: str, spans: list[tuple[int, int]], assigned: dict[str, list[tuple[int, _Literal | None]]],
           hints: set[str]) -> tuple[np.ndarray | None, str | None]:
    """The joint values [rad] of ``get_inverse_kin``'s ``qnear`` (its second argument, or ``qnear=``: a joint literal
    or a variable assigned one once), None when not given; and why the call is not read (None: it is). A variable read
    is added to ``hints``."""
    near_text = None
    for k, span in enumerate(spans):
        a, b = stripped(text, span)
        keyword = re.match(r"([A-Za-z_]\w*)[ \t]*=(?!=)[ \t]*", text[a:b])
        key = keyword.group(1) if keyword else "qnear" if k == 0 else "?"
        if key == "qnear":
            near_text = (a + keyword.end() if keyword else a, b)
        elif key not in ("maxPositionError", "maxOrientationError"):
            return None, f"its argument '{text[a:b][:30]}' is not read (the TCP given to the call?)"
    if near_text is None:
        return None, None
    word = text[near_text[0]:near_text[1]]
    if _NAME.fullmatch(word):
        hints.add(word)
        where = assigned.get(word, [])
        literal = where[0][1] if len(where) == 1 else None
    else:
        literal = _literal(text, *near_text)
    if literal is None or literal.pose:
        return None, f"qnear '{word[:30]}' is not a joint literal […] nor a variable assigned one once"
    return np.array(literal.values), None


def _add(program: Program, file: str, line: int, name: str, literal: _Literal, tool: pin.SE3 | None, tool_line: int,
         uses: tuple[int, ...], near: np.ndarray | None = None) -> None:
    if not literal.pose:
        program.targets.append(Target(file, line, name, np.array(literal.values), None, pin.SE3.Identity(),
                                      pin.SE3.Identity(), "joints", None, uses,
                                      render_joints=joint_render(file, literal.spans, 1.0, DECIMALS)))
        return
    if tool is None:
        program.problems.append(Problem(file, line, f"'{name}': the TCP set at line {tool_line} is not a literal: "
                                                    "left as written"))
        return
    context = f"TCP of set_tcp at line {tool_line}" if tool_line else "the TCP given (--tcp), no set_tcp above"
    program.targets.append(Target(file, line, name, None, _pose(literal.values), tool, pin.SE3.Identity(), context,
                                  _render(file, literal), uses, near=near))
