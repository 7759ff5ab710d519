"""The leaderboard (`robocog leaderboard`) and submissions (`robocog submit prepare | validate`), from
real studies of the scripted models (a study of the paper's tasks and a small robocog-v1 study), the
committed results file written before provenance, and rows tagged with capabilities; the page opened
from file:// in Chromium.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from robocog.agent.analysis.results_file import read_rows
from robocog.agent.analysis.scores import family_row
from robocog.agent.cli.main import main
from robocog.shared.provenance import sha256_of
from tests.browser import browser_page, chromium, screenshot_path
from tests.e2e.test_bundle import eval_study
from tests.helpers import DATA

SUITE = """
name: suite-small
models:
  - {model: scripted/planner, label: planner}
  - {model: scripted/overconfident, label: overconfident-0.3, params: {p: 0.3}}
suite: robocog-v1
split: dev
instances: 4
trials: 2
memory_iterations: 1
workers: 2
"""


@pytest.fixture(scope="module")
def studies(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """paper-tasks: the scripted models on T1, T2 (2 trials); suite: 4 robocog-v1 dev instances x 2
    trials; old: the committed file without provenance; tagged: the suite's rows as another study
    whose rows carry capability tags (as a robocog-v2 suite's will)."""
    folder = tmp_path_factory.mktemp("studies")
    paper = eval_study(folder / "paper-tasks.jsonl", "--trials", "2", "--memory-iterations", "1")
    config = folder / "suite.yaml"
    config.write_text(SUITE)
    suite = eval_study(folder / "suite.jsonl", config=config)
    tags = {"bring": ["navigation", "manipulation"], "put_away": ["manipulation", "long-horizon"]}
    tagged = folder / "tagged.jsonl"
    tagged.write_text(
        "".join(
            r.model_copy(
                update={"study": "tagged", "model": f"{r.model}-tagged", "capabilities": tags.get(r.family or "", [])}
            ).model_dump_json()
            + "\n"
            for r in read_rows(suite)
        )
    )
    for study in (paper, suite, tagged):  # replayed in the physics: the record beside each
        replayed = main(["submit", "verify", str(study)])
        assert replayed == 0
    return {"paper": paper, "suite": suite, "old": DATA / "results_paper.jsonl", "tagged": tagged}


def board_of(out: Path) -> dict[str, Any]:
    return dict(json.loads((out / "leaderboard.json").read_text()))


def entries(out: Path) -> dict[str, dict[str, Any]]:
    return {f"{e['model']} ({e['protocol']})": e for e in board_of(out)["entries"]}


def test_the_leaderboard_scores_with_the_report_s_code_and_marks_what_is_verified(
    studies: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "board"
    assert (
        main(["leaderboard", str(studies["paper"]), str(studies["suite"]), str(studies["old"]), "--out", str(out)]) == 0
    )
    said = capsys.readouterr().out
    assert said == f"leaderboard: {out / 'index.html'} (6 entries from 3 studies, 3 verified)\n"
    got = entries(out)
    assert set(got) == {
        "planner (robocog)", "overconfident-0.3 (robocog)", "refuser (robocog)",
        "alpha (paper)", "beta (paper)", "gamma (paper)",
    }  # fmt: skip
    planner = got["planner (robocog)"]
    pooled = [r for f in ("paper", "suite") for r in read_rows(studies[f]) if r.model == "planner"]
    reference = family_row("planner", "all", pooled)
    assert planner["attempts"] == len(pooled) == 4 + 8
    assert planner["success"] == round(reference.success, 4) and planner["verified"] is True
    assert planner["pass_k"] == {str(k): v for k, v in reference.pass_k.items()}
    assert set(planner["families"]) == {"T1", "T2", "bring", "put_away", "rearrange", "swap"}
    assert planner["studies"] == ["paper-tasks.jsonl", "suite.jsonl"]
    alpha = got["alpha (paper)"]
    assert alpha["verified"] is False and alpha["problems"][0].startswith("no provenance")
    over = got["overconfident-0.3 (robocog)"]
    assert over["false_success_rate"] is not None and over["false_success_rate"] > 0
    assert board_of(out)["capabilities"] == []  # robocog-v1 rows carry no capability tags
    assert (out / "success_cost.png").stat().st_size > 10_000
    assert "| 1 | planner | robocog | yes (12 of 12 replayed) |" in (out / "leaderboard.md").read_text()
    assert (planner["replayed"], got["alpha (paper)"]["replayed"]) == (12, 0)


def test_an_edited_prompt_or_a_missing_trace_is_not_verified(studies: dict[str, Path], tmp_path: Path) -> None:
    rows = read_rows(studies["paper"])
    edited = studies["paper"].with_name("edited.jsonl")  # beside the study: its traces resolve
    changed = []
    for r in rows:
        if r.model == "planner" and r.provenance is not None:
            r = r.model_copy(update={"provenance": r.provenance.model_copy(update={"system_prompt_sha256": "0" * 64})})
        changed.append(r.model_copy(update={"trace": None}) if r.model == "refuser" else r)
    edited.write_text("".join(r.model_dump_json() + "\n" for r in changed))
    assert main(["submit", "verify", str(edited)]) == 1  # the refuser's attempts have no trace to replay
    out = tmp_path / "board"
    assert main(["leaderboard", str(edited), "--out", str(out)]) == 0
    got = entries(out)
    assert got["planner (robocog)"]["problems"] == ["system prompt robot_system differs from the shipped one (4 rows)"]
    assert got["refuser (robocog)"]["problems"] == ["trace missing (2 rows)", "not replayed (2 rows)"]
    assert got["overconfident-0.3 (robocog)"]["verified"] is True


@pytest.mark.anyio
async def test_the_page_from_disk_is_sortable_with_capability_columns_and_the_plot(
    studies: dict[str, Path], tmp_path: Path
) -> None:
    chromium()
    out = tmp_path / "board"
    given = [str(studies[k]) for k in ("paper", "suite", "old", "tagged")]
    assert main(["leaderboard", *given, "--out", str(out)]) == 0
    async with browser_page(1500, 900) as page:
        problems: list[str] = []
        page.on("pageerror", lambda e: problems.append(str(e)))
        await page.goto((out / "index.html").resolve().as_uri())
        await page.wait_for_function("document.body.dataset.ready === 'true'")
        rows = page.locator("#board tbody tr")
        assert await rows.count() == 8
        heads = await page.locator("#board thead th").all_text_contents()
        assert heads[:7] == ["#", "model", "protocol", "verified", "attempts", "success", "false success"]
        assert await page.get_attribute("#board thead th[data-column='5']", "aria-sort") == "descending"
        assert [h for h in heads if h in ("long-horizon", "manipulation", "navigation")] == [
            "long-horizon", "manipulation", "navigation",
        ]  # fmt: skip
        successes = await page.locator("#board tbody tr td:nth-child(6)").all_text_contents()
        values = [float(s.split("%")[0]) for s in successes]
        assert values == sorted(values, reverse=True)
        await page.click("#board thead th[data-column='5']")  # success, ascending now
        assert await page.get_attribute("#board", "data-sort") == "success ascending"
        values = [
            float(s.split("%")[0]) for s in await page.locator("#board tbody tr td:nth-child(6)").all_text_contents()
        ]
        assert values == sorted(values)
        await page.click("#board thead th[data-column='1']")  # model, a text column: A to Z first
        models = await page.locator("#board tbody tr td:nth-child(2)").all_text_contents()
        assert models == sorted(models)
        marks = dict(
            zip(models, await page.locator("#board tbody tr td:nth-child(4)").all_text_contents(), strict=True)
        )
        assert marks["planner"] == "✓ verified12 of 12 replayed" and marks["alpha"] == "unverified0 of 11 replayed"
        nav = heads.index("navigation")
        tagged = page.locator("#board tbody tr[data-model='planner-tagged'] td").nth(nav)
        assert (await tagged.text_content() or "").endswith("%")
        await page.wait_for_function("document.getElementById('plot').naturalWidth > 500")
        await page.click("#board thead th[data-column='5']")  # success, highest first again
        assert await page.get_attribute("#board", "data-sort") == "success descending"
        await page.screenshot(path=str(screenshot_path("leaderboard.png")), full_page=True)
        assert problems == []


def test_a_submission_validates_merges_and_refuses_tampering(
    studies: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sub = tmp_path / "submission.json"
    assert main(["submit", "prepare", str(studies["paper"]), "--out", str(sub)]) == 0
    assert capsys.readouterr().out == f"submission: {sub} (10 rows, 3 models)\n"
    data = json.loads(sub.read_text())
    assert (data["suite"], data["tasks"], data["trials_per_instance"]) == (None, ["T1", "T2"], 2)
    assert all(len(t) == 64 for t in data["traces"])
    assert main(["submit", "validate", str(sub)]) == 0
    assert capsys.readouterr().out == (
        f"{sub}: valid (10 rows, 2 trials per instance, T1, T2); ran on what robocog ships (to verify it, replay it: "
        "robocog submit verify)\n"
    )
    assert main(["submit", "verify", str(sub)]) == 0

    out = tmp_path / "board"  # a submission from elsewhere beside a results file from here
    assert main(["leaderboard", str(sub), str(studies["suite"]), "--out", str(out)]) == 0
    capsys.readouterr()
    assert entries(out)["refuser (robocog)"]["studies"] == ["submission.json"]
    assert entries(out)["planner (robocog)"]["verified"] is True

    def bad(change: dict[str, object], rehash: bool = False) -> str:
        changed = {**data, **change}
        if rehash:
            changed["rows_sha256"] = sha256_of(changed["rows"])
        path = tmp_path / "bad.json"
        path.write_text(json.dumps(changed))
        assert main(["submit", "validate", str(path)]) == 2
        err = capsys.readouterr().err
        return err.splitlines()[0]

    tampered = [dict(r) for r in data["rows"]]
    tampered[0]["true_success"] = not tampered[0]["true_success"]
    assert bad({"rows": tampered}).endswith(
        "not a valid submission: rows_sha256 does not match the rows (edited after robocog submit prepare?)"
    )
    assert bad({"traces": ["xyz", *data["traces"][1:]]}).endswith("the trace digest of row 1 is not a sha256")
    drop = next(i for i, r in enumerate(data["rows"]) if r["task"] == "T1")  # (T2 runs only after T1 succeeded)
    kept = {
        "rows": data["rows"][:drop] + data["rows"][drop + 1 :],
        "traces": data["traces"][:drop] + data["traces"][drop + 1 :],
        "trace_texts": data["trace_texts"][:drop] + data["trace_texts"][drop + 1 :],
    }
    assert bad(kept, rehash=True).endswith(
        f"{data['rows'][drop]['model']} has 1 trials of T1 at memory iteration 0, not 2"
    )
    assert bad({"format": "other/9"}).endswith("format 'other/9' is not 'robocog-submission/1'")
    assert main(["leaderboard", str(tmp_path / "bad.json"), "--out", str(out)]) == 2
    assert "not a valid submission" in capsys.readouterr().err

    partial = tmp_path / "partial.json"
    assert main(["submit", "prepare", str(studies["suite"]), "--out", str(partial)]) == 0
    warned = capsys.readouterr().err
    assert "planner covers 4 of the 70 of robocog-v1/dev" in warned
    assert main(["submit", "validate", str(partial)]) == 2
    err = capsys.readouterr().err.splitlines()  # the models in name order, one line each
    assert err[0].startswith(f"robocog: {partial}: not a valid submission: overconfident-0.3 covers 4 of the 70")
    assert err[1].startswith(f"robocog: {partial}: also: planner covers 4 of the 70 of robocog-v1/dev (")


def test_bad_input_gets_one_line_and_exit_2(
    studies: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = str(tmp_path / "out")
    garbage = tmp_path / "garbage.jsonl"
    garbage.write_text("not json\n{}\n")
    cases = [
        (["leaderboard", str(tmp_path / "missing.jsonl"), "--out", out], "missing.jsonl: no such file"),
        (["leaderboard", str(garbage), "--out", out], "garbage.jsonl: not a results file of robocog eval (line 1"),
        (["leaderboard", str(studies["paper"]), str(studies["paper"]), "--out", out], "hold the same attempts"),
        (["submit", "prepare", str(tmp_path / "missing.jsonl"), "--out", out], "no such results file"),
        (["submit", "validate", str(garbage)], "not JSON"),
        (["submit", "validate", str(tmp_path / "missing.json")], "missing.json: no such submission"),
    ]
    for argv, message in cases:
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and err.startswith("robocog: ") and message in err, (argv, err)


def _counted_study(path: Path, successes: int, attempts: int) -> Path:
    """A results file of one model's `attempts` attempts at T1 (two trials per memory iteration),
    `successes` of them true (86/132 = 65.15…%: a share whose last digit a second rounding changes)."""
    template = read_rows(DATA / "results_paper.jsonl")[0]
    rows = [
        template.model_copy(
            update={
                "model": "counted",
                "study": "counted",
                "trial": i % 2,
                "memory_iteration": i // 2,
                "seed": i % 2,
                "true_success": i < successes,
            }
        )
        for i in range(attempts)
    ]
    path.write_text("".join(r.model_dump_json() + "\n" for r in rows))
    return path


@pytest.mark.anyio
async def test_the_page_and_the_markdown_show_the_same_digits_and_fit_1280_px(
    studies: dict[str, Path], tmp_path: Path
) -> None:
    """Every cell of every entry reads the same on the page (Chromium, 1,280 px wide) as in
    leaderboard.md; 86/132 reads 65.2% in both; the table needs no horizontal scroll."""
    chromium()
    out = tmp_path / "board"
    counted = _counted_study(tmp_path / "counted.jsonl", 86, 132)
    given = [str(studies[k]) for k in ("paper", "suite", "old", "tagged")] + [str(counted)]
    assert main(["leaderboard", *given, "--out", str(out)]) == 0
    markdown = [
        [c.strip() for c in line.strip("|").split(" | ")]
        for line in (out / "leaderboard.md").read_text().splitlines()
        if line.startswith("| ") and not line.startswith("| #")
    ]
    by_model = {cells[1]: cells for cells in markdown}
    assert by_model["counted"][5].startswith("65.2% [")
    async with browser_page(1280, 900) as page:
        await page.goto((out / "index.html").resolve().as_uri())
        await page.wait_for_function("document.body.dataset.ready === 'true'")
        rows = await page.evaluate(
            """() => {
                const texts = (n) => (n.nodeType === 3 ? [n.textContent.trim()] : [...n.childNodes].flatMap(texts));
                return [...document.querySelectorAll('#board tbody tr')].map((tr) =>
                    [...tr.children].map((td) => texts(td).filter((t) => t).join(' ')));
            }"""
        )
        assert len(rows) == len(markdown) == 9
        for cells in rows:
            written = by_model[cells[1]]
            shown = [written[0], written[1], *written[2:]]
            verified = cells[3].replace("✓ verified ", "yes (").replace("unverified ", "no (") + ")"
            assert [cells[0], cells[1], cells[2], verified, *cells[4:]] == shown, cells[1]
        wrap = await page.evaluate(
            "(() => { const w = document.querySelector('.wrap'); return [w.scrollWidth, w.clientWidth]; })()"
        )
        await page.screenshot(path=str(screenshot_path("leaderboard-1280.png")), full_page=True)
        assert wrap[0] <= wrap[1], f"the table is {wrap[0]} px wide in a {wrap[1]} px box at 1,280 px"
