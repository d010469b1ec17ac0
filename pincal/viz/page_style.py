"""The look of pincal's report pages: the style sheet (the calibration report and the page of ``pincal check``) and the
script by which the calibration report hears from its 3D scene."""

from __future__ import annotations

STYLE = """
body { font: 14px/1.45 system-ui, -apple-system, "Segoe UI", sans-serif; color: #1d2733; margin: 0;
  background: #f4f6f9; }
main { max-width: 1120px; margin: 0 auto; padding: 18px 24px 40px; }
h1 { font-size: 24px; margin: 6px 0 2px; } h2 { font-size: 18px; margin: 28px 0 8px; }
.sub { color: #5b6775; margin: 0 0 14px; }
.cards { display: flex; gap: 12px; flex-wrap: wrap; }
.card { background: #fff; border-radius: 8px; padding: 10px 14px; box-shadow: 0 1px 3px rgba(0,0,0,.12);
  flex: 1 1 220px; }
.card .what { color: #5b6775; font-size: 12px; text-transform: uppercase; letter-spacing: .03em; }
.card .nums { font-size: 20px; font-variant-numeric: tabular-nums; }
.before { color: #c0392b; } .after { color: #1e8449; } .gain { font-size: 13px; color: #1e8449; }
.verdict { background: #eaf6ee; border-left: 4px solid #1e8449; padding: 8px 12px; margin: 14px 0; }
.warn { background: #fdf1e6; border-left: 4px solid #e67e22; padding: 8px 12px; margin: 14px 0; }
iframe { width: 100%; height: 560px; border: 0; border-radius: 8px; box-shadow: 0 1px 3px rgba(0,0,0,.15);
  background: #fff; }
.caption { color: #5b6775; font-size: 12px; margin: 4px 0 0; }
table { border-collapse: collapse; background: #fff; font-variant-numeric: tabular-nums; }
th, td { padding: 3px 10px; border-bottom: 1px solid #e3e7ec; text-align: right; }
th:first-child, td:first-child { text-align: left; }
th { background: #eef1f5; font-weight: 600; }
tr.unidentified td { color: #8a939e; }
figure { margin: 8px 0; background: #fff; border-radius: 8px; padding: 6px; display: inline-block;
  box-shadow: 0 1px 3px rgba(0,0,0,.12); }
figure img { max-width: 100%; display: block; }
ul.combos li { margin: 3px 0; }
code { background: #eef1f5; padding: 0 3px; border-radius: 3px; }
"""

SCENE_LISTENER = """
window.addEventListener("message", function (e) {
  if (!e.data || !e.data.pincalScene) return;
  var s = e.data.pincalScene, out = document.getElementById("scene-status");
  out.setAttribute("data-status", JSON.stringify(s));
  out.textContent = "3D scene loaded: " + s.robot_calibrated + " shapes per robot (" + s.frames.join(", ") +
    "), " + s.points + " samples" + (s.webgl ? "" : " — WebGL unavailable in this browser");
});
"""
