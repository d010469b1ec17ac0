"""``pincal filter`` on what shop-floor programs hold beyond the examples: a point changed by the program after its
declaration, a tool set for one move, Polyscope's ``movej(get_inverse_kin(…))``. A point the program moves to with
another value than the one written, or with another tool than pincal read, must be named and left as written, never
rewritten for a pose the robot is not sent to. The robot's own URDF as the model (nothing moves): no calibration."""

from __future__ import annotations

from pathlib import Path

from conftest import ROOT, run_pincal

KR16 = ROOT / "examples" / "data" / "robots" / "kr16_like.urdf"
UR_POSE = "p[-0.45, -0.55, 0.20, 2.2214, -2.2214, 0.0]"


def _filter(program: Path, *options: str) -> tuple[int, str, str]:
    out = program.parent / "out" / program.name
    done = run_pincal("filter", str(program), "--out", str(out), *options)
    assert "Traceback" not in done.stderr, done.stderr
    return done.returncode, done.stdout + done.stderr, out.read_text(encoding="utf-8") if out.exists() else ""


def test_urscript_pose_variable_changed_by_an_expression_is_named_and_left(tmp_path: Path) -> None:
    program = tmp_path / "cell.script"
    text = (f"def cell():\n  global Pick_p={UR_POSE}\n  movel(Pick_p, a=1.2, v=0.25)\n"
            "  Pick_p = pose_add(Pick_p, p[0, 0, 0.1, 0, 0, 0])\n  movel(Pick_p, a=1.2, v=0.25)\nend\n")
    program.write_text(text, encoding="utf-8")
    code, said, written = _filter(program, "--model", "ur10")
    assert code == 1, said
    assert "cell.script line 3: target 'Pick_p': assigned 2 times" in said
    assert "0 Cartesian" in said and written == text
