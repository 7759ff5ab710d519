"""`make conformance`: the official MCP conformance suite against `robocog-server --transport http`.

Installs the pinned `@modelcontextprotocol/conformance` with npm into `.cache/conformance` (once),
starts the server on a free loopback port, runs every server scenario that applies to robocog one
by one, prints one line per scenario and exits 1 if any fails. The suite's other scenarios call
fixtures that only its reference server has (`test_*` tools, `test://` resources, `test_*`
prompts); `EXCLUDED` says so for each. A scenario the pinned suite lists that is in neither table
fails the run, so a new version cannot slip scenarios past us.
"""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = "@modelcontextprotocol/conformance"
#: 0.1.12 runs on Node 20; later releases need Node 22.
VERSION = "0.1.12"
CACHE = ROOT / ".cache" / "conformance"
SUITE = CACHE / "node_modules" / ".bin" / "conformance"
SERVER = ROOT / ".venv" / "bin" / "robocog-server"

#: The scenarios that apply to any MCP server, robocog included.
APPLICABLE = (
    "server-initialize",
    "ping",
    "logging-set-level",
    "completion-complete",
    "tools-list",
    "resources-list",
    "resources-subscribe",
    "resources-unsubscribe",
    "prompts-list",
    "server-sse-multiple-streams",
    "dns-rebinding-protection",
)

_TOOL = "calls the reference server's {} tool, which robocog does not have"
#: The scenarios that test the suite's reference server, and why each does not apply to robocog.
EXCLUDED = {
    "tools-call-simple-text": _TOOL.format("test_simple_text") + " (it passes anyway: the unknown-tool error is text)",
    "tools-call-image": _TOOL.format("test_image_content"),
    "tools-call-audio": _TOOL.format("test_audio_content"),
    "tools-call-embedded-resource": _TOOL.format("test_embedded_resource"),
    "tools-call-mixed-content": _TOOL.format("test_multiple_content_types"),
    "tools-call-with-logging": _TOOL.format("test_tool_with_logging"),
    "tools-call-error": _TOOL.format("test_error_handling") + " (it passes anyway: the unknown-tool error is an error)",
    "tools-call-with-progress": _TOOL.format("test_tool_with_progress"),
    "tools-call-sampling": _TOOL.format("test_sampling") + "; robocog never asks the client to sample",
    "tools-call-elicitation": _TOOL.format("test_elicitation") + "; robocog never elicits",
    "elicitation-sep1034-defaults": _TOOL.format("test_elicitation_sep1034_defaults") + "; robocog never elicits",
    "elicitation-sep1330-enums": _TOOL.format("test_elicitation_sep1330_enums") + "; robocog never elicits",
    "json-schema-2020-12": _TOOL.format("json_schema_2020_12_tool") + " (a pending scenario)",
    "server-sse-polling": _TOOL.format("test_reconnection") + " (a pending scenario)",
    "resources-read-text": "reads the reference server's test://static-text resource",
    "resources-read-binary": "reads the reference server's test://static-binary resource",
    "resources-templates-read": "reads the reference server's test://template/{id}/data template",
    "prompts-get-simple": "gets the reference server's test_simple_prompt prompt",
    "prompts-get-with-args": "gets the reference server's test_prompt_with_arguments prompt",
    "prompts-get-embedded-resource": "gets the reference server's test_prompt_with_embedded_resource prompt",
    "prompts-get-with-image": "gets the reference server's test_prompt_with_image prompt",
}


def install() -> None:
    """The pinned suite in .cache/conformance (npm's own cache makes a reinstall cheap)."""
    installed = CACHE / "node_modules" / "@modelcontextprotocol" / "conformance" / "package.json"
    if installed.exists() and f'"version": "{VERSION}"' in installed.read_text(encoding="utf-8"):
        return
    CACHE.mkdir(parents=True, exist_ok=True)
    print(f"conformance: installing {PACKAGE}@{VERSION} into {CACHE.relative_to(ROOT)}", flush=True)
    command = ["npm", "install", "--prefix", str(CACHE), "--no-audit", "--no-fund", f"{PACKAGE}@{VERSION}"]
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL)


def listed_scenarios() -> list[str]:
    out = subprocess.run([str(SUITE), "list", "--server"], check=True, capture_output=True, text=True).stdout
    return [line.strip()[2:] for line in out.splitlines() if line.strip().startswith("- ")]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port: int = s.getsockname()[1]
        return port


def wait_for(port: int, server: subprocess.Popen[bytes], timeout_s: float = 60.0) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if server.poll() is not None:
            raise SystemExit(f"conformance: robocog-server exited with {server.returncode} before listening")
        with socket.socket() as s:
            if s.connect_ex(("127.0.0.1", port)) == 0:
                return
        time.sleep(0.1)
    raise SystemExit(f"conformance: robocog-server did not listen on port {port} within {timeout_s:.0f} s")


def run_scenario(url: str, scenario: str) -> tuple[bool, str]:
    """(passed, the suite's output) of one scenario."""
    command = [str(SUITE), "server", "--url", url, "--scenario", scenario]
    done = subprocess.run(command, capture_output=True, text=True, timeout=120)
    return done.returncode == 0, done.stdout + done.stderr


def main() -> int:
    if shutil.which("node") is None or shutil.which("npm") is None:  # .ci/run skips before this
        print("conformance: node and npm are needed (Node.js 20 or later)", file=sys.stderr)
        return 2
    install()
    unknown = sorted(set(listed_scenarios()) - set(APPLICABLE) - set(EXCLUDED))
    if unknown:
        print(f"conformance: scenarios neither run nor excluded: {', '.join(unknown)}", file=sys.stderr)
        return 1
    port = free_port()
    url = f"http://127.0.0.1:{port}/mcp"
    with tempfile.TemporaryDirectory(prefix="robocog-conformance-") as data:
        command = [str(SERVER), "--transport", "http", "--port", str(port), "--data-dir", data]
        server = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=os.environ.copy())
        try:
            wait_for(port, server)
            failed = []
            for scenario in APPLICABLE:
                passed, output = run_scenario(url, scenario)
                print(f"conformance: {'pass' if passed else 'FAIL'}  {scenario}", flush=True)
                if not passed:
                    failed.append(scenario)
                    print(output, file=sys.stderr)
        finally:
            server.terminate()
            server.wait(timeout=10)
    print(
        f"conformance: {len(APPLICABLE) - len(failed)}/{len(APPLICABLE)} applicable scenarios pass "
        f"({PACKAGE}@{VERSION}; {len(EXCLUDED)} excluded: reference-server fixtures)"
    )
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
