"""turbid.sweep and incomplete journal entries: the item runs again and the summary says so."""
import json

import turbid

EXPERIMENT = {
    "name": "journal",
    "seed": 3,
    "scale": 0.1,
    "scenes": ["builtin:seafloor"],
    "grid": {"water.beta_gray_per_m": [0.4, 1.0, 2.0]},
    "methods": ["clahe", "dcp"],
    "metrics": ["psnr"],
    "thumbnails": 0,
}


def test_an_entry_without_its_method_rows_is_run_again_with_a_note(tmp_path):
    out = str(tmp_path / "out")
    first = turbid.sweep(EXPERIMENT, out)
    assert first["ran"] == 3 and first["notes"] == []
    reference = (tmp_path / "out" / "items.csv").read_text()
    journal = tmp_path / "out" / "journal.jsonl"
    entries = [json.loads(line) for line in journal.read_text().splitlines()]
    entries[1]["methods"] = entries[1]["methods"][:1]  # the dcp row is lost
    journal.write_text("".join(json.dumps(e) + "\n" for e in entries))
    (tmp_path / "out" / "summary.md").unlink()  # the tables are written again

    again = turbid.sweep(EXPERIMENT, out)
    assert again["ran"] == 1 and again["already_done"] == 2
    assert len(again["notes"]) == 1
    assert f"the entry of item '{entries[1]['id']}' is incomplete" in again["notes"][0]
    assert (tmp_path / "out" / "items.csv").read_text() == reference
