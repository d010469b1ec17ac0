"""KUKA KRL programs read for ``pincal filter`` (docs/filter_krl.md): a ``.src`` and its ``.dat``.

Targets are the points of ``PTP``, ``LIN``, ``CIRC`` (two) and their spline forms ``SPTP``, ``SLIN``, ``SCIRC``: a
variable declared once with an aggregate (``DECL E6POS XP1={X …,Y …,Z …,A …,B …,C …,S …,T …}``, ``POS``, ``FRAME``;
``E6AXIS``, ``AXIS`` for joints), in the ``.dat`` or the ``.src``, or an aggregate written in the move. Positions are in
millimetres, angles in degrees (``R = Rz(A) Ry(B) Rx(C)``; joints ``A1 … A6``). A Cartesian point is the TCP of the
active ``$TOOL`` in the active ``$BASE``: ``$TOOL = TOOL_DATA[n]``, ``$BASE = BASE_DATA[n]``, a literal frame,
``BAS(#TOOL, n)``, ``BAS(#BASE, n)`` or the ``TOOL_NO``/``BASE_NO`` of the ``FDAT_ACT`` of an inline form, in the order
the ``.src`` sets them; ``TOOL_DATA[n]`` and ``BASE_DATA[n]`` are read from the program's files and the further files
given (the controller's ``$config.dat``). Base 0 and tool 0 are ``$NULLFRAME``; before any is set, the tool given and
the robot's base. A relative move, a point that lacks a coordinate, an unknown tool or base, an expression in a point's
place are problems, left as written. The status and turn (``S``, ``T``: numbers or bit strings) are read for the
filter to check and rewrite (:mod:`pincal.calibration.arm_posture`); external axes are kept.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable

import numpy as np
import pinocchio as pin

from pincal.errors import DataError
from pincal.io.programs import (
    Edit,
    NamedPosture,
    Problem,
    Program,
    Target,
    closing,
    comment_free,
    euler_zyx_near,
    joint_render,
    line_of,
    number_text,
    split_top,
    stripped,
    zyx_rotation,
)

#: Decimals written: millimetres and degrees (1e-4 mm, 1e-5°).
MM_DECIMALS, DEGREE_DECIMALS = 4, 5
CARTESIAN = ("E6POS", "POS", "FRAME")
JOINTS = ("E6AXIS", "AXIS")

_MOVE = re.compile(r"^[ \t]*(S?PTP|S?LIN|S?CIRC)(_REL)?\b", re.IGNORECASE | re.MULTILINE)
_DECL = re.compile(r"^[ \t]*(?:DECL[ \t]+)?(?:GLOBAL[ \t]+)?(E6POS|POS|FRAME|E6AXIS|AXIS|FDAT)[ \t]+(\w+)[ \t]*=[ \t]*"
                   r"(?=\{)", re.IGNORECASE | re.MULTILINE)
_DATA = re.compile(r"\b(TOOL_DATA|BASE_DATA)[ \t]*\[[ \t]*(\d+)[ \t]*\][ \t]*=[ \t]*(?=\{)", re.IGNORECASE)
_SET = re.compile(r"^[ \t]*(\$TOOL|\$BASE)[ \t]*=[ \t]*(.*)$", re.IGNORECASE | re.MULTILINE)
_BAS = re.compile(r"^[ \t]*BAS[ \t]*\([ \t]*#(TOOL|BASE)[ \t]*,[ \t]*(\d+)[ \t]*\)", re.IGNORECASE | re.MULTILINE)
_FDAT = re.compile(r"^[ \t]*FDAT_ACT[ \t]*=[ \t]*(\w+)", re.IGNORECASE | re.MULTILINE)
#: An assignment in the ``.src`` to a variable or a part of it (``XP1 = XP2``, ``XP1.Z = XP1.Z + 50``): a point
#: changed so goes where the program puts it, not where its declaration says.
_CHANGE = re.compile(r"^[ \t]*([A-Za-z_]\w*)[ \t]*(?:\.[ \t]*\w+[ \t]*|\[[^\]\n]*\][ \t]*)*=(?!=)", re.MULTILINE)
_WORD = re.compile(r"[A-Za-z_$]\w*")
_FIELD = re.compile(r"\s*([A-Za-z_]\w*(?:\[\])?)\s+(.*?)\s*$", re.DOTALL)


def aggregate(text: str, opening: int) -> tuple[dict[str, tuple[str, int, int]], int] | None:
    """The fields of the aggregate ``{NAME value, …}`` at ``opening``: name (upper case) → (value text, its span), and
    the index of its closing brace; None when it is not one."""
    close = closing(text, opening)
    if close < 0:
        return None
    fields: dict[str, tuple[str, int, int]] = {}
    for span in split_top(text, opening + 1, close):
        a, b = stripped(text, span)
        if a == b:
            continue
        match = _FIELD.match(text, a, b)
        if match is None:
            return None
        fields[match.group(1).upper()] = (text[match.start(2):match.end(2)], match.start(2), match.end(2))
    return fields, close


def _float(value: str) -> float | None:
    try:
        return float(value)
    except ValueError:
        return None


def frame_of(fields: dict[str, tuple[str, int, int]]) -> pin.SE3 | None:
    """The frame of an aggregate's X, Y, Z [mm], A, B, C [°] in SI units; None when one is missing or not a number."""
    values = [_float(fields[k][0]) if k in fields else None for k in "XYZABC"]
    if any(v is None for v in values):
        return None
    x, y, z, a, b, c = (float(v) for v in values)  # type: ignore[arg-type]
    return pin.SE3(zyx_rotation(*(math.radians(v) for v in (a, b, c))), np.array([x, y, z]) / 1e3)


def _joints(fields: dict[str, tuple[str, int, int]]) -> np.ndarray | None:
    names = sorted((k for k in fields if re.fullmatch(r"A\d", k)), key=lambda k: int(k[1:]))
    values = [_float(fields[k][0]) for k in names]
    if not names or any(v is None for v in values) or names != [f"A{k + 1}" for k in range(len(names))]:
        return None
    return np.asarray(np.radians(np.array(values, dtype=float)), dtype=float)


def _render(file: str, fields: dict[str, tuple[str, int, int]]) -> Callable[[pin.SE3], list[Edit]]:
    old = [math.radians(float(fields[k][0])) for k in "ABC"]

    def render(pose: pin.SE3) -> list[Edit]:
        angles = [math.degrees(v) for v in euler_zyx_near(pose.rotation, old)]
        new = [*(pose.translation * 1e3).tolist(), *angles]
        decimals = [MM_DECIMALS] * 3 + [DEGREE_DECIMALS] * 3
        return [Edit(file, fields[k][1], fields[k][2], number_text(v, d))
                for k, v, d in zip("XYZABC", new, decimals, strict=True)]
    return render


class _State:
    """The active tool and base as the ``.src`` sets them, by line."""

    def __init__(self, tcp: pin.SE3, world: pin.SE3) -> None:
        self.tool: tuple[pin.SE3 | None, str] = (tcp, "the TCP given (--tcp), no $TOOL set above")
        self.base: tuple[pin.SE3 | None, str] = (world, "the robot's base, no $BASE set above")


_ROBROOT = re.compile(r"^[ \t]*(?:DECL[ \t]+)?(?:GLOBAL[ \t]+)?(?:FRAME[ \t]+)?\$ROBROOT[ \t]*=[ \t]*(?=\{)",
                      re.IGNORECASE | re.MULTILINE)


def robroot(extra: dict[str, str]) -> tuple[pin.SE3, str] | None:
    """The robot's base in ``$WORLD``: the ``$ROBROOT`` a further file declares (the controller's ``$machine.dat``),
    with where, in words; None when none does.

    Raises:
        DataError: declared more than once, or not a frame of X, Y, Z [mm], A, B, C [°].
    """
    found = []
    for name, text in extra.items():
        code = comment_free(text, ";")
        for match in _ROBROOT.finditer(code):
            fields = aggregate(code, match.end())
            frame = frame_of(fields[0]) if fields else None
            line = line_of(text, match.start())
            where = f"{name} line {line}"
            if frame is None:
                raise DataError(f"$ROBROOT at {where}: not a frame of X, Y, Z, A, B, C", file=name, line=line)
            found.append((frame, f"$ROBROOT of {where}", name, line))
    if len(found) > 1:  # the fields name the second declaration
        raise DataError(f"$ROBROOT is declared {len(found)} times ({', '.join(w[12:] for _, w, _, _ in found)}): give "
                        "one $machine.dat", file=found[1][2], line=found[1][3])
    return found[0][:2] if found else None


def _data_entries(name: str, text: str, code: str, data: dict[tuple[str, int], tuple[pin.SE3 | None, str]]) -> None:
    """The ``TOOL_DATA[n]``, ``BASE_DATA[n]`` file ``name`` declares (``code``: its text without comments) put in
    ``data``: each frame [m, rad] and where; one declared differently in two places is None, with both places."""
    for match in _DATA.finditer(code):
        found = aggregate(code, match.end())
        frame = frame_of(found[0]) if found else None
        key, at = (match.group(1).upper(), int(match.group(2))), f"{name} line {line_of(text, match.start())}"
        before = data.get(key)
        if before is None:
            data[key] = (frame, at)
        elif before[0] is None or frame is None or not before[0].isApprox(frame, 1e-12):
            data[key] = (None, f"{key[0]}[{key[1]}] is declared differently in {before[1]} and {at}")


def read_krl(src: str, src_file: str, dat: str | None, dat_file: str, extra: dict[str, str],
             tcp: pin.SE3, world: pin.SE3 | None = None) -> Program:
    """The targets of a KRL program (module docstring): its ``.src`` text, its ``.dat`` text (None when it has none),
    the further files' texts by name; ``tcp`` the tool until the program sets one; ``world`` the robot's base in
    ``$WORLD`` (``$ROBROOT``), the base of points before the program sets one (default: the identity). The targets'
    frames are in ``$WORLD``: :func:`~pincal.io.program_reader.read_program` puts them in the robot's base."""
    texts = {src_file: src, **({dat_file: dat} if dat is not None else {})}
    program = Program("krl", texts)
    data: dict[tuple[str, int], tuple[pin.SE3 | None, str]] = {}
    declared: dict[str, list[tuple[str, int, str, dict[str, tuple[str, int, int]]]]] = {}
    for name, text in {**texts, **extra}.items():
        code = comment_free(text, ";")
        _data_entries(name, text, code, data)
        if name in extra:
            if _DATA.search(code) is None and _ROBROOT.search(code) is None:
                program.problems.append(Problem(name, 1, "--config file: no TOOL_DATA, BASE_DATA nor $ROBROOT "
                                                         "declared in it: nothing read"))
            continue
        for match in _DECL.finditer(code):
            found = aggregate(code, match.end())
            if found is None:
                program.problems.append(Problem(name, line_of(text, match.start()), f"'{match.group(2)}': its "
                                                                                     "aggregate is not read"))
                continue
            declared.setdefault(match.group(2).upper(), []).append(
                (name, line_of(text, match.start()), match.group(1).upper(), found[0]))
    code = comment_free(src, ";")
    state = _State(tcp, pin.SE3.Identity() if world is None else world)
    events = sorted([(m.start(), "set", m) for m in _SET.finditer(code)] + [(m.start(), "bas", m) for m in
                    _BAS.finditer(code)] + [(m.start(), "fdat", m) for m in _FDAT.finditer(code)] +
                    [(m.start(), "move", m) for m in _MOVE.finditer(code)], key=lambda e: e[0])
    uses: dict[str, list[tuple[int, tuple[pin.SE3 | None, str], tuple[pin.SE3 | None, str]]]] = {}
    for position, kind, match in events:
        line = line_of(src, position)
        if kind == "set":
            _set(state, match, code, data, program, src_file, line)
        elif kind == "bas":
            _select(state, match.group(1).upper(), int(match.group(2)), data)
        elif kind == "fdat":
            _fdat(state, match.group(1).upper(), declared, data, program, src_file, line)
        else:
            moved = _with(state, code, match.end(), declared, data, program, src_file, line)
            _move(program, src_file, src, code, match, line, moved or state, uses)
            if moved is not None:  # the WITH's tool and base are the move's: set again before the next point
                state.tool = (None, f"the tool after the WITH of line {line} (valid for that move; set it again)")
                state.base = (None, f"the base after the WITH of line {line} (valid for that move; set it again)")
    changed: dict[str, int] = {}
    for match in _CHANGE.finditer(code):
        changed.setdefault(match.group(1).upper(), line_of(src, match.start(1)))
    for variable, where in uses.items():
        lines = tuple(line for line, _, _ in where)
        if variable in changed:
            shown = f"line{'s' if len(lines) > 1 else ''} {', '.join(map(str, lines))}"
            program.problems.append(Problem(src_file, changed[variable], f"point '{variable}' is changed by the "
                                                                         f"program here (its moves: {shown}): left "
                                                                         "as written"))
            continue
        entries = declared.get(variable, [])
        kinds = {k for _, _, k, _ in entries}
        if len(entries) != 1 or not kinds & {*CARTESIAN, *JOINTS}:
            why = "never declared with an aggregate" if not entries else f"declared {len(entries)} times"
            if not entries and dat is None:
                why += f" (the .src has no .dat beside it: {dat_file} is missing)"
            program.problems.append(Problem(src_file, lines[0], f"point '{variable}': {why}: left as written"))
            continue
        file, line, kind, fields = entries[0]
        contexts = {(id(t[0]), id(b[0])) for _, t, b in where}
        if kind in CARTESIAN and len(contexts) > 1:
            program.problems.append(Problem(file, line, f"'{variable}' is reached with {len(contexts)} tool and base "
                                                        f"pairs (lines {', '.join(map(str, lines))}): left as written"))
            continue
        _add(program, file, line, variable, kind, fields, where[0][1], where[0][2], lines)
    for variable, entries in declared.items():
        if variable not in uses and any(k in (*CARTESIAN, *JOINTS) for _, _, k, _ in entries):
            file, line, _, _ = entries[0]
            program.problems.append(Problem(file, line, f"'{variable}' is a point no move of the .src reads: left as "
                                                        "written"))
    program.targets.sort(key=lambda t: t.uses[0] if t.uses else t.line)
    return program


_WITH = re.compile(r"[ \t]WITH\b", re.IGNORECASE)
_WITH_SET = re.compile(r"\$(TOOL|BASE|IPO_MODE)[ \t]*=[ \t]*(.+)", re.IGNORECASE | re.DOTALL)
_FROM_FDAT = re.compile(r"(?:STOOL2|SBASE|SIPO_MODE)[ \t]*\([ \t]*(\w+)(?:[ \t]*\.[ \t]*(\w+))?[ \t]*\)", re.IGNORECASE)


def _with(state: _State, code: str, start: int, declared: dict[str, list[tuple[str, int, str, dict[str, tuple[str,
          int, int]]]]], data: dict[tuple[str, int], tuple[pin.SE3 | None, str]], program: Program, file: str,
          line: int) -> _State | None:
    """The tool and base of the move whose keyword ends at ``start`` when its ``WITH`` clause sets them (KSS 8's spline
    inline forms: ``$TOOL = STOOL2(FP1), $BASE = SBASE(FP1.BASE_NO), $IPO_MODE = SIPO_MODE(FP1.IPO_FRAME)``; or
    ``TOOL_DATA[n]``, ``BASE_DATA[n]``, ``$NULLFRAME``); None when it sets neither. A value not read makes the tool
    or base unknown (the move's points left as written, with a problem)."""
    end = code.find("\n", start)
    end = len(code) if end < 0 else end
    found = _WITH.search(code, start, end)
    if found is None:
        return None
    values = {}
    for span in split_top(code, found.end(), end):
        assignment = _WITH_SET.fullmatch(code, *stripped(code, span))
        if assignment:
            values[assignment.group(1).upper()] = assignment.group(2).strip()
    if "TOOL" not in values and "BASE" not in values:
        return None
    moved = _State(pin.SE3.Identity(), pin.SE3.Identity())
    moved.tool, moved.base = state.tool, state.base
    for which, value in values.items():
        fdat = _FROM_FDAT.fullmatch(value)
        if which == "IPO_MODE":
            entries = [f for f in declared.get(fdat.group(1).upper(), []) if f[2] == "FDAT"] if fdat else []
            mode = entries[0][3].get("IPO_FRAME", ("#BASE", 0, 0))[0] if len(entries) == 1 else value
            if mode.strip().upper() != "#BASE":
                program.problems.append(Problem(file, line, f"WITH $IPO_MODE = {value[:30]}: not read as #BASE (a "
                                                             "stationary tool?): its points are left as written"))
                moved.tool = (None, f"the tool of an $IPO_MODE {value[:30]}, which pincal does not read")
            continue
        number: int | None = None
        if fdat is not None and (fdat.group(2) or f"{which}_NO").upper() == f"{which}_NO":
            entries = [f for f in declared.get(fdat.group(1).upper(), []) if f[2] == "FDAT"]
            field_ = entries[0][3].get(f"{which}_NO") if len(entries) == 1 else None
            number = int(field_[0]) if field_ is not None and field_[0].strip().isdigit() else None
        indexed = re.fullmatch(rf"{which}_DATA[ \t]*\[[ \t]*(\d+)[ \t]*\]", value, re.IGNORECASE)
        number = int(indexed.group(1)) if indexed else 0 if value.upper() == "$NULLFRAME" else number
        if number is not None:
            _select(moved, which, number, data)
            continue
        program.problems.append(Problem(file, line, f"WITH ${which} = {value[:30]}: not read; the move's points are "
                                                     "left as written"))
        unknown = (None, f"${which} = {value[:30]} of the WITH at line {line}, which pincal does not read")
        if which == "TOOL":
            moved.tool = unknown
        else:
            moved.base = unknown
    return moved


def _select(state: _State, which: str, number: int, data: dict[tuple[str, int], tuple[pin.SE3 | None, str]]) -> None:
    name = f"{which}_DATA"
    if number == 0:
        value: tuple[pin.SE3 | None, str] = (pin.SE3.Identity(), f"{name}[0] ($NULLFRAME)")
    elif (name, number) in data:
        frame, where = data[(name, number)]
        value = (None, where) if where.startswith(f"{name}[") else (frame, f"{name}[{number}] ({where})")
    else:
        value = (None, f"{name}[{number}], which no file given holds (give the controller's $config.dat with --config)")
    if which == "TOOL":
        state.tool = value
    else:
        state.base = value


def _set(state: _State, match: re.Match[str], code: str, data: dict[tuple[str, int], tuple[pin.SE3 | None, str]],
         program: Program, file: str, line: int) -> None:
    which = match.group(1).upper()[1:]
    value = match.group(2).strip()
    indexed = re.fullmatch(rf"{which}_DATA[ \t]*\[[ \t]*(\d+)[ \t]*\]", value, re.IGNORECASE)
    if indexed:
        _select(state, which, int(indexed.group(1)), data)
        return
    if value.upper() == "$NULLFRAME":
        _select(state, which, 0, data)
        return
    found = aggregate(code, match.start(2)) if value.startswith("{") else None
    frame = frame_of(found[0]) if found else None
    words = (frame, f"the frame set at line {line}") if frame is not None else (
        None, f"${which} = {value[:30]} at line {line}, which pincal does not read")
    if frame is None:
        program.problems.append(Problem(file, line, f"${which} = {value[:30]}: not a TOOL_DATA/BASE_DATA entry nor "
                                                     "a frame aggregate; the moves below it are left as written"))
    if which == "TOOL":
        state.tool = words
    else:
        state.base = words


def _fdat(state: _State, name: str, declared: dict[str, list[tuple[str, int, str, dict[str, tuple[str, int, int]]]]],
          data: dict[tuple[str, int], tuple[pin.SE3 | None, str]], program: Program, file: str, line: int) -> None:
    found = [f for f in declared.get(name, []) if f[2] == "FDAT"]
    fields = found[0][3] if len(found) == 1 else {}
    tool, base = fields.get("TOOL_NO"), fields.get("BASE_NO")
    ipo = fields.get("IPO_FRAME", ("#BASE", 0, 0))[0].upper()
    if tool is None or base is None or not tool[0].isdigit() or not base[0].isdigit() or ipo != "#BASE":
        program.problems.append(Problem(file, line, f"FDAT_ACT = {name}: its TOOL_NO, BASE_NO (and IPO_FRAME #BASE) "
                                                     "are not read; the moves below it are left as written"))
        state.tool = (None, f"the tool of {name}, which pincal does not read")
        return
    _select(state, "TOOL", int(tool[0]), data)
    _select(state, "BASE", int(base[0]), data)


def _move(program: Program, file: str, src: str, code: str, match: re.Match[str], line: int, state: _State,
          uses: dict[str, list[tuple[int, tuple[pin.SE3 | None, str], tuple[pin.SE3 | None, str]]]]) -> None:
    keyword = match.group(1).upper()
    if match.group(2):
        program.problems.append(Problem(file, line, f"{keyword}{match.group(2).upper()}: a relative move, left as "
                                                    "written"))
        return
    count = 2 if keyword.endswith("CIRC") else 1
    k = match.end()
    for index in range(count):
        while k < len(code) and code[k] in " \t":
            k += 1
        if code.startswith("{", k):
            found = aggregate(code, k)
            if found is None:
                program.problems.append(Problem(file, line, f"{keyword}: its point is not read"))
                return
            fields, close = found
            kind = "E6AXIS" if any(re.fullmatch(r"A\d", f) for f in fields) else "E6POS"
            _add(program, file, line, keyword, kind, fields, state.tool, state.base, (line,))
            k = close + 1
        else:
            word = _WORD.match(code, k)
            following = code[word.end():word.end() + 1] if word else ""
            if word is None or following in ("[", ".", "("):
                end = code.find("\n", k)
                shown = code[k:end if end >= 0 else len(code)].strip()[:30]
                program.problems.append(Problem(file, line, f"{keyword}: point '{shown}' is neither a variable nor an "
                                                            "aggregate: left as written"))
                return
            uses.setdefault(word.group(0).upper(), []).append((line, state.tool, state.base))
            k = word.end()
        if index + 1 < count:
            while k < len(code) and code[k] in " \t":
                k += 1
            if not code.startswith(",", k):
                program.problems.append(Problem(file, line, f"{keyword}: its second point is not read"))
                return
            k += 1


def _add(program: Program, file: str, line: int, name: str, kind: str, fields: dict[str, tuple[str, int, int]],
         tool: tuple[pin.SE3 | None, str], base: tuple[pin.SE3 | None, str], uses: tuple[int, ...]) -> None:
    if kind in JOINTS:
        joints = _joints(fields)
        if joints is None:
            program.problems.append(Problem(file, line, f"'{name}': its axes A1, A2, … are not all numbers"))
            return
        if len(joints) < 6:
            program.problems.append(Problem(file, line, f"'{name}': a partial axis point (A1 … A{len(joints)}) moves "
                                                        "the other axes from wherever they are: not read as a target"))
            return
        spans = [(fields[f"A{k + 1}"][1], fields[f"A{k + 1}"][2]) for k in range(len(joints))]
        program.targets.append(Target(file, line, name, joints, None, pin.SE3.Identity(), pin.SE3.Identity(),
                                      "joints", None, uses,
                                      render_joints=joint_render(file, spans, 180 / math.pi, DEGREE_DECIMALS)))
        return
    pose = frame_of(fields)
    if pose is None:
        program.problems.append(Problem(file, line, f"'{name}': not every one of X, Y, Z, A, B, C is a number (a "
                                                    "partial point moves from wherever the robot is): left as "
                                                    "written"))
        return
    if tool[0] is None or base[0] is None:
        unknown = tool[1] if tool[0] is None else base[1]
        program.problems.append(Problem(file, line, f"'{name}': its tool or base is not known: {unknown}; left as "
                                                    "written"))
        return
    program.targets.append(Target(file, line, name, None, pose, tool[0], base[0], f"tool {tool[1]}, base {base[1]}",
                                  _render(file, fields), uses, _posture(file, fields)))


def _posture(file: str, fields: dict[str, tuple[str, int, int]]) -> NamedPosture | None:
    """The status and turn a point writes (``S 6``, ``T 'B100011'``); None when it writes neither as a number."""
    found: dict[str, tuple[int, int, int]] = {}
    binary = set()
    for name in ("S", "T"):
        if name not in fields:
            continue
        text, start, end = fields[name]
        bits = re.fullmatch(r"'[Bb]([01]+)'", text.strip())
        if bits:
            found[name] = (int(bits.group(1), 2), start, end)
            binary.add(name)
        elif text.strip().isdigit():
            found[name] = (int(text), start, end)
    return NamedPosture("krl", file, found, frozenset(binary)) if found else None
