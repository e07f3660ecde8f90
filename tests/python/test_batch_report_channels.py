"""core/batch_report: the channels a clip's target had no place for are a column of the report (JSON, CSV)."""
from core import batch_report, channel_carry


def test_the_channels_left_out_are_written_and_read_back(tmp_path):
    line = channel_carry.summary([channel_carry.LeftOut("shape_key", "tongueOut", "no mesh of the target has it")])
    rows = [batch_report.new_row("a.fbx", "", "a"), batch_report.new_row("b.fbx", "", "b")]
    rows[0]["channels_left_out"] = line
    assert "channels_left_out" in batch_report.COLUMNS
    json_path, csv_path = batch_report.write(rows, str(tmp_path))
    read = batch_report.read(str(tmp_path))
    assert [r.get("channels_left_out") for r in read] == [line, None]
    with open(csv_path, encoding="utf-8") as f:
        assert "channels_left_out" in f.readline() and "tongueOut (no mesh of the target has it)" in f.read()
