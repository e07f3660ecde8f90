"""A batch's report: one row per clip, as JSON and CSV beside the outputs and as a table for the console,
sortable by what needs a look. No bpy here."""
from __future__ import annotations

import csv
import json
import math
import os

COLUMNS = ("file", "take", "action", "status", "reason", "frames", "fps", "bones_mapped", "fingers_mapped",
           "sliding_median_mm", "sliding_worst_mm", "floor_above_mm", "floor_below_mm", "direction_worst_deg",
           "direction_worst_bone", "pop_worst_deg", "pop_bone", "pop_frame", "body", "channels_left_out", "seconds",
           "output")
# The console table: (column, heading, width)
_TABLE = (("action", "clip", 28), ("status", "status", 7), ("frames", "frames", 6), ("bones_mapped", "bones", 5),
          ("fingers_mapped", "fing", 4), ("sliding_worst_mm", "slide mm", 8), ("floor_above_mm", "above mm", 8),
          ("floor_below_mm", "below mm", 8), ("direction_worst_deg", "dir deg", 7), ("pop_worst_deg", "pop deg", 7),
          ("seconds", "s", 6))


def new_row(path: str, take: str, action: str, status: str = "ok", reason: str = "") -> dict:
    row = dict.fromkeys(COLUMNS)
    row.update(file=path, take=take, action=action, status=status, reason=reason, output="")
    return row


def _plain(value):
    """JSON has no NaN: a figure that is not a number is None."""
    return None if isinstance(value, float) and not math.isfinite(value) else value


def write(rows: list[dict], folder: str) -> tuple[str, str]:
    """report.json and report.csv in folder; returns their paths."""
    os.makedirs(folder, exist_ok=True)
    json_path, csv_path = os.path.join(folder, "report.json"), os.path.join(folder, "report.csv")
    clean = [{k: _plain(row.get(k)) for k in COLUMNS} for row in rows]
    with open(json_path, "w", encoding="utf-8") as f:
        json.dump({"clips": clean, "failed": sum(r["status"] == "failed" for r in clean)}, f, indent=1)
    with open(csv_path, "w", encoding="utf-8", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=COLUMNS)
        writer.writeheader()
        writer.writerows({k: "" if v is None else v for k, v in row.items()} for row in clean)
    return json_path, csv_path


def read(folder: str) -> list[dict]:
    with open(os.path.join(folder, "report.json"), encoding="utf-8") as f:
        return json.load(f)["clips"]


def _cell(value, width: int) -> str:
    if value is None:
        text = "-"
    elif isinstance(value, float):
        text = f"{value:.1f}"
    else:
        text = str(value)
    return text if len(text) <= width else text[:width - 1] + "\u2026"


def table(rows: list[dict]) -> str:
    """The rows as a fixed-width table, failures' reasons under it."""
    lines = ["  ".join(f"{heading:<{width}}" for _, heading, width in _TABLE)]
    lines += ["  ".join(f"{_cell(row.get(key), width):<{width}}" for key, _, width in _TABLE) for row in rows]
    failed = [row for row in rows if row["status"] != "ok"]
    lines += [f"{row['status']}: {row['file']}{' | ' + row['take'] if row['take'] else ''}: {row['reason']}"
              for row in failed]
    lines.append(f"{len(rows)} clips, {sum(r['status'] == 'ok' for r in rows)} done, "
                 f"{sum(r['status'] == 'failed' for r in rows)} failed, {sum(r['status'] == 'skipped' for r in rows)} skipped")
    return "\n".join(lines)
