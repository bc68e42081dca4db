"""report.html of `compare` and `study`, opened in a real headless browser (Debian's chromium,
installed by `make setup-browser`, which `make test` runs): every picture decodes, and the
tables' figures are comparison.json's (table.json's)."""
import json
import shutil
import subprocess
from html.parser import HTMLParser

import pytest

from cli.main import main
from test_compare import member


class Tables(HTMLParser):
    """{table id: rows of cell texts} and the <body> attributes of a page."""

    def __init__(self):
        super().__init__()
        self.tables, self.body, self._id, self._row = {}, {}, None, None
        self.text = ""

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "body":
            self.body = a
        elif tag == "table":
            self._id = a.get("id")
            self.tables[self._id] = []
        elif tag == "tr" and self._id is not None:
            self._row = []
            self.tables[self._id].append(self._row)
        elif tag in ("td", "th") and self._row is not None:
            self._row.append("")

    def handle_endtag(self, tag):
        if tag == "table":
            self._id = self._row = None

    def handle_data(self, data):
        self.text += data
        if self._row:
            self._row[-1] += data


def browser_dom(page):
    """The page's DOM after its scripts ran, as chromium --headless dumps it."""
    chromium = shutil.which("chromium")
    if chromium is None:
        pytest.fail("chromium is not installed: `make setup-browser` (Debian's chromium)")
    proc = subprocess.run([chromium, "--headless", "--no-sandbox", "--disable-gpu",
                           "--virtual-time-budget=10000", "--dump-dom", page.as_uri()],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return proc.stdout


def figure(text):
    return None if text == "n/a" else float(text)


def close(cell, value):
    """A table cell against its comparison.json figure, printed to 4 significant digits."""
    return (value is None and cell == "n/a") or figure(cell) == pytest.approx(value, rel=5e-4)


def test_compare_report_opens_in_a_browser_with_every_picture_and_figure(tmp_path):
    for seed, a in zip((1, 2, 3), (0.9, 1.0, 1.1)):
        member(tmp_path / "full" / f"seed-{seed}", "full", seed, a, s_per_step=3.0)
    for seed, a in zip((1, 2), (1.02, 1.3)):
        member(tmp_path / "coupled" / f"seed-{seed}", "coupled", seed, a, volume=0.9)
    out = tmp_path / "cmp"
    assert main(["compare", str(tmp_path / "full"), str(tmp_path / "coupled"), "--out",
                 str(out)]) == 0
    page = Tables()
    page.feed(browser_dom(out / "report.html"))
    images = int(page.body["data-images"])
    assert images == 5 + 2 * 2      # QoIs, profiles, cracking maps, two ensembles; two a pair
    assert page.body["data-images-decoded"] == page.body["data-images"]
    r = json.loads((out / "comparison.json").read_text())
    rows = page.tables["yardstick"][1:]
    j = r["judgement"]["qoi"]
    assert sorted((row[0], row[1]) for row in rows) == sorted((n, s) for n in j for s in j[n])
    for name, statistic, _, difference, _, se, margin, verdict in rows:
        v = j[name][statistic]
        assert close(difference, v["difference"]) and close(se, v["se"])
        assert close(margin, v["margin"]) and verdict.startswith(v["verdict"])
    assert r["headline"] in page.text
    w = r["ensemble"]["within_full_scatter"]
    verdicts = page.tables["verdicts"][1:]
    assert sorted(row[0] for row in verdicts) == sorted(w["sensors"])
    for row in verdicts:
        v = w["sensors"][row[0]]
        assert close(row[1], v["nrms"]["coupled_max"])
        assert close(row[2], v["nrms"]["full_leave_one_out_max"])
        assert row[3].startswith("within") == v["nrms"]["within"]
        assert close(row[4], v["peak"]["coupled_max"])
        assert close(row[5], v["peak"]["full_leave_one_out_max"])
    assert any(row[3] == "OUTSIDE" for row in verdicts)       # seed 2 at 1.3 × lies outside
    for row in page.tables["damage-verdicts"][1:]:
        v = w["damage"][row[0]]
        assert close(row[1], v["coupled_max"]) and close(row[2], v["full_leave_one_out_max"])
    pairs = page.tables["pairs"][1:]
    assert len(pairs) == 2 * 4
    for seed, sensor, peak, nrms, *_ in pairs:
        s = r["pairs"][seed]["sensors"][sensor]
        assert close(peak, s["peak_ratio"]) and close(nrms, s["nrms"])
    for seed, volume, _, speedup, _ in page.tables["pair-figures"][1:]:
        p = r["pairs"][seed]
        assert close(volume, p["damage"]["damaged_volume_ratio"])
        assert close(speedup, p["speedup_per_step"])


def test_study_report_opens_in_a_browser_with_the_table_and_its_picture(tmp_path):
    from cases.slab.study import report, table as st
    from test_study import FULL, members, runs_at
    runs = runs_at(40.0)
    members(tmp_path, runs, "full", FULL, s_per_step=3.0)
    members(tmp_path, runs, "box-0.5m", {s: 1.01 * a for s, a in FULL.items()},
            s_per_step=0.5)
    table = st.build(runs, tmp_path)
    table["table1"] = None
    (impact,) = table["impacts"]
    report.plot_impact(impact, tmp_path / f"{impact['group']}.png")
    report.write(table, tmp_path, "page.md", "# page\n")
    page = Tables()
    page.feed(browser_dom(tmp_path / "report.html"))
    assert page.body["data-images"] == page.body["data-images-decoded"] == "1"
    rows = {row[0]: row for row in page.tables[f"impact-{impact['group']}"][1:]}
    row = next(r for r in impact["configs"] if r["config"] == "box-0.5m")
    shown = rows["box-0.5m"]
    assert shown[4] == f"{row['speedup']['value']:.2f} (runs)"
    assert shown[5] == f"{row['judged']['equivalent']} of {row['judged']['total']}"
    assert shown[8] == "none"
