"""Wrong prompt arguments over a real stdio server: one line for the caller (invalid params), and no
traceback in the server's log, however often the call comes."""

from __future__ import annotations

from pathlib import Path

from mcp_types import INVALID_PARAMS

from tests.e2e.test_attack import RawStdioServer


def test_a_prompt_with_wrong_arguments_is_one_line_and_no_traceback(tmp_path: Path) -> None:
    log = tmp_path / "server.log"
    server = RawStdioServer("--data-dir", str(tmp_path / "memory"), log=log)
    try:
        for _ in range(3):
            answer = server.answer(server.send("prompts/get", {"name": "T1", "arguments": {"x": "y"}}))
            assert answer["error"] == {
                "code": INVALID_PARAMS,
                "message": "prompt 'T1' takes no arguments (unexpected: x)",
            }
        answer = server.answer(server.send("prompts/get", {"name": "bring", "arguments": {"object": "mug"}}))
        assert answer["error"]["message"] == "prompt 'bring' takes object, location (missing: location)"
        answer = server.answer(server.send("prompts/get", {"name": "T9", "arguments": {}}))
        assert answer["error"]["message"].startswith("unknown prompt 'T9'; the prompts are: "), answer
        ok = server.answer(
            server.send("prompts/get", {"name": "bring", "arguments": {"object": "mug", "location": "Kitchen Table"}})
        )
        assert ok["result"]["messages"][0]["content"]["text"] == "Bring the mug to Kitchen Table."
    finally:
        server.close()
    assert "Traceback" not in log.read_text(encoding="utf-8", errors="replace")
