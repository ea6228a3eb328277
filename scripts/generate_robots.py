"""Regenerate robots/*.urdf from mpd_pin.arm.builtin.BUILTIN_ARMS (run from the repository root)."""

from pathlib import Path

from mpd_pin.arm.builtin import BUILTIN_ARMS

out = Path(__file__).resolve().parent.parent / "robots"
out.mkdir(exist_ok=True)
for name, spec in BUILTIN_ARMS.items():
    (out / f"{name}.urdf").write_text(spec.urdf(), encoding="utf-8")
    print(f"wrote {out / (name + '.urdf')}")
