"""Packaging: the MCP Registry entry (server.json), the MCP Bundle (dist/robocog.mcpb) and versions.

- server.json validates against the registry's published schema (a copy in packaging/registry/),
  its description fits the registry's 100 characters, and its version is the package's.
- The bundle's manifest names the published contract's tools and the settings a user can set; its
  entry point turns those settings into robocog-server's options.
- The bundle runs one Python, locked with a wheel of every package on every platform its manifest
  claims; the project requires one build of the physics in each environment.
- Each setting reaches the server as one word and is checked first; a bad one is refused naming it.
- The bundle, unpacked, starts the way a desktop host starts it: the manifest's command with its
  variables substituted, from `/`, with only PATH set (and UV_OFFLINE=1: see packaging/README.md),
  lists its tools over stdio, and with "Confirm before acting" on tells a client that cannot ask
  its user to turn that setting off.
"""

from __future__ import annotations

import importlib.util
import json
import os
import re
import selectors
import shutil
import subprocess
import sys
import time
import tomllib
import zipfile
from pathlib import Path
from types import ModuleType
from typing import Any

import jsonschema
import pytest

from tests.helpers import APP_TOOLS, ROBOT_TOOLS

REPO = Path(__file__).resolve().parents[2]
PACKAGING = REPO / "packaging"
BUNDLE = REPO / "dist" / "robocog.mcpb"


def load_json(path: Path) -> Any:
    """A JSON file's content."""
    return json.loads(path.read_text(encoding="utf-8"))


def package_version() -> str:
    """The version in pyproject.toml."""
    with open(REPO / "pyproject.toml", "rb") as f:
        return str(tomllib.load(f)["project"]["version"])


def launcher() -> ModuleType:
    """The bundle's entry point (packaging/bundle/server/main.py), imported from its file."""
    spec = importlib.util.spec_from_file_location("robocog_bundle_main", PACKAGING / "bundle" / "server" / "main.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


# --- the registry entry ------------------------------------------------------------------------------


def test_server_json_validates_against_the_registry_schema() -> None:
    schema = load_json(PACKAGING / "registry" / "server.schema.json")
    entry = load_json(REPO / "server.json")
    validator = jsonschema.Draft7Validator(schema, format_checker=jsonschema.Draft7Validator.FORMAT_CHECKER)
    errors = [f"{list(e.absolute_path)}: {e.message}" for e in validator.iter_errors(entry)]
    assert errors == []
    assert entry["$schema"] == schema["$id"]
    assert len(entry["description"]) <= 100


def test_the_registry_schema_rejects_a_long_description() -> None:
    """The copy of the schema is the real one: it holds the registry's limits."""
    schema = load_json(PACKAGING / "registry" / "server.schema.json")
    entry = load_json(REPO / "server.json") | {"description": "x" * 101}
    assert not jsonschema.Draft7Validator(schema).is_valid(entry)


def test_versions_agree_with_the_package() -> None:
    version = package_version()
    entry = load_json(REPO / "server.json")
    manifest = load_json(PACKAGING / "bundle" / "manifest.json")
    assert entry["version"] == version
    assert [p["version"] for p in entry["packages"]] == [version] * len(entry["packages"])
    assert manifest["version"] == version


# --- the bundle's manifest and entry point -----------------------------------------------------------


def test_manifest_names_the_published_tools_and_the_user_settings() -> None:
    manifest = load_json(PACKAGING / "bundle" / "manifest.json")
    contract = load_json(REPO / "assets" / "contract" / "default.json")
    assert manifest["manifest_version"] == "0.4"
    assert manifest["server"]["type"] == "uv"
    assert (PACKAGING / "bundle" / manifest["server"]["entry_point"]).is_file()
    assert sorted(t["name"] for t in manifest["tools"]) == sorted(t["name"] for t in contract["tools"])
    assert set(manifest["user_config"]) == {"memory_dir", "scene", "viewer_port", "confirm_actions"}
    args = manifest["server"]["mcp_config"]["args"]
    for key in manifest["user_config"]:  # each setting one word: `--option=${user_config.KEY}`
        assert len([a for a in args if "${user_config." + key + "}" in a]) == 1
        assert any(re.fullmatch(r"--[a-z-]+=\$\{user_config\." + key + r"\}", a) for a in args), key


@pytest.mark.parametrize(
    ("given", "expected"),
    [
        (
            ["--data-dir=/m", "--scene=flat", "--view=0", "--confirm=true"],
            ["--data-dir=/m", "--scene=flat", "--view=0", "--confirm-actions"],
        ),
        (["--data-dir=", "--scene=household", "--confirm=false"], ["--scene=household"]),
        (["--data-dir=${user_config.memory_dir}", "--view=8766.0"], ["--view=8766"]),
        (["--log-level", "INFO"], ["--log-level", "INFO"]),
    ],
)
def test_entry_point_turns_settings_into_server_options(given: list[str], expected: list[str]) -> None:
    assert launcher().server_argv(given) == expected


def test_a_setting_never_becomes_an_option_of_its_own() -> None:
    """Values that look like options reach robocog-server as the values of their settings."""
    from robocog.server.cli_options import build_parser

    given = ["--data-dir=--profile=eval", "--scene=--allow-tools=look_around", "--view=0"]
    args = build_parser().parse_args(launcher().server_argv(given))
    assert (args.data_dir, args.scene, args.view) == (Path("--profile=eval"), Path("--allow-tools=look_around"), 0)
    assert (args.profile, args.allow_tools) == ("default", None)


@pytest.mark.parametrize(
    ("given", "said"),
    [
        ("--view=--profile=eval", "the setting 'Viewer port' is '--profile=eval': not a port number"),
        ("--view=65536", "the setting 'Viewer port' is '65536': not a port number"),
        ("--view=80.5", "the setting 'Viewer port' is '80.5': not a port number"),
        ("--confirm=--allow-tools=look_around", "the setting 'Confirm before acting' is "),
        ("--data-dir=" + __file__, "the setting 'Memory directory' is "),
    ],
)
def test_entry_point_refuses_a_bad_setting_naming_it(given: str, said: str) -> None:
    with pytest.raises(ValueError, match="^" + re.escape(said)):
        launcher().server_argv([given])


def test_robocog_server_refuses_a_view_that_is_not_a_port(capsys: pytest.CaptureFixture[str]) -> None:
    from robocog.server.cli_options import build_parser

    for value in ("--profile=eval", "", "70000"):
        with pytest.raises(SystemExit) as exited:
            build_parser().parse_args([f"--view={value}"])
        assert exited.value.code == 2
        assert "robocog-server: error: argument --view: " in capsys.readouterr().err


def bundled(name: str) -> str:
    """A file of dist/robocog.mcpb, as text (skips when the bundle is not built)."""
    if not BUNDLE.exists():
        pytest.skip("dist/robocog.mcpb is missing: build it with `make bundle`")
    with zipfile.ZipFile(BUNDLE) as bundle:
        return bundle.read(name).decode("utf-8")


def builder() -> ModuleType:
    """packaging/build_bundle.py, imported from its file."""
    spec = importlib.util.spec_from_file_location("robocog_build_bundle", PACKAGING / "build_bundle.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclass looks its module up
    spec.loader.exec_module(module)
    return module


def test_the_bundle_runs_one_python_with_wheels_on_every_platform_it_claims() -> None:
    """The bundle's project pins the Python the manifest names, and is locked for the manifest's
    platforms only, with a wheel of every package required in each (uv refuses to lock otherwise) and
    no build from source at install."""
    manifest = json.loads(bundled("manifest.json"))
    project = tomllib.loads(bundled("pyproject.toml"))
    python = builder().BUNDLE_PYTHON
    assert project["project"]["requires-python"] == f"=={python}.*"
    assert bundled(".python-version").strip() == python
    low, high = python.split(".")
    assert manifest["compatibility"]["runtimes"]["python"] == f">={low}.{high} <{low}.{int(high) + 1}"
    claimed = [t.marker for p in manifest["compatibility"]["platforms"] for t in builder().PLATFORMS[p]]
    assert project["tool"]["uv"]["environments"] == claimed
    assert project["tool"]["uv"]["required-environments"] == claimed
    assert project["tool"]["uv"]["no-build"] is True
    lock = tomllib.loads(bundled("uv.lock"))
    assert lock["requires-python"] == f"=={python}.*"

    def terms(markers: list[str]) -> set[frozenset[str]]:
        return {frozenset(m.split(" and ")) for m in markers}

    assert terms(lock["required-markers"]) == terms(lock["supported-markers"]) == terms(claimed)


@pytest.mark.parametrize(
    ("platform", "machine", "python", "physics"),
    [
        ("linux", "x86_64", "3.11", "pybullet"),
        ("linux", "x86_64", "3.12", "pybullet-arm64"),
        ("linux", "x86_64", "3.13", "pybullet-arm64"),
        ("darwin", "arm64", "3.11", "pybullet-arm64"),
        ("darwin", "x86_64", "3.12", "pybullet-arm64"),
        ("win32", "AMD64", "3.11", "pybullet-arm64"),
    ],
)
def test_one_physics_build_per_environment(platform: str, machine: str, python: str, physics: str) -> None:
    """The project requires exactly one of the two builds of the `pybullet` module in each environment:
    upstream where its wheels are (Linux, CPython 3.11), the fork everywhere else."""
    from packaging.requirements import Requirement

    with open(REPO / "pyproject.toml", "rb") as f:
        requirements = [Requirement(r) for r in tomllib.load(f)["project"]["dependencies"]]
    environment = {"sys_platform": platform, "platform_machine": machine, "python_version": python}
    wanted = [
        r.name
        for r in requirements
        if r.name in ("pybullet", "pybullet-arm64") and (r.marker is None or r.marker.evaluate(environment))
    ]
    assert wanted == [physics]


def test_the_wheel_carries_every_asset() -> None:
    """A wheel install is as complete as a checkout: every file under assets/ is in the wheel."""
    if not BUNDLE.exists():
        pytest.skip("dist/robocog.mcpb is missing: build it with `make bundle`")
    with zipfile.ZipFile(BUNDLE) as bundle:
        (wheel_name,) = [n for n in bundle.namelist() if n.startswith("wheels/") and n.endswith(".whl")]
        with zipfile.ZipFile(bundle.open(wheel_name)) as wheel:
            in_wheel = set(wheel.namelist())
    assets = REPO / "assets"
    shipped = [p for p in assets.rglob("*") if p.is_file() and "__pycache__" not in p.parts]
    names = [p.relative_to(REPO).as_posix() for p in shipped]
    missing = sorted(name for name in names if f"robocog/{name}" not in in_wheel)
    assert missing == []


# --- the bundle, started as a host starts it ---------------------------------------------------------


def substitute(value: str, dirname: Path, settings: dict[str, str]) -> str:
    """A host's variable substitution in mcp_config: ${__dirname} and ${user_config.KEY}."""
    value = value.replace("${__dirname}", str(dirname))
    return re.sub(r"\$\{user_config\.(\w+)\}", lambda m: settings.get(m.group(1), ""), value)


def rpc(proc: subprocess.Popen[bytes], message: dict[str, Any], timeout_s: float) -> dict[str, Any] | None:
    """Send one JSON-RPC message over the server's stdin; for a request, wait for its response."""
    assert proc.stdin is not None and proc.stdout is not None
    proc.stdin.write((json.dumps(message) + "\n").encode())
    proc.stdin.flush()
    if "id" not in message:
        return None
    selector = selectors.DefaultSelector()
    selector.register(proc.stdout, selectors.EVENT_READ)
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if not selector.select(timeout=max(0.0, deadline - time.monotonic())):
            break
        line = proc.stdout.readline()
        if not line:
            break
        reply = json.loads(line)
        if reply.get("id") == message["id"]:
            return dict(reply)
    raise AssertionError(f"no answer to {message['method']} within {timeout_s:g} s")


def seed_environment(bundle_dir: Path) -> None:
    """The bundle's .venv as a hard-linked copy of this virtualenv, so uv finds its packages offline."""
    if sys.prefix == sys.base_prefix:
        pytest.skip("the bundle's offline start needs the tests to run in a virtualenv (make test)")
    result = subprocess.run(["cp", "-al", sys.prefix, str(bundle_dir / ".venv")], capture_output=True, text=True)
    if result.returncode != 0:
        pytest.skip(f"cannot hard-link the virtualenv next to the bundle (another filesystem?): {result.stderr}")


def test_bundle_starts_as_a_host_does(tmp_path: Path) -> None:
    if not BUNDLE.exists():
        pytest.skip("dist/robocog.mcpb is missing: build it with `make bundle` (CI does, before `make test`)")
    uv = shutil.which("uv", path=str(Path(sys.executable).parent)) or shutil.which("uv")
    if uv is None:
        pytest.skip("uv is not installed: the dev extra installs it (pip install -e '.[dev]')")
    started = time.monotonic()
    bundle_dir = tmp_path / "robocog.mcpb.d"
    with zipfile.ZipFile(BUNDLE) as zf:
        zf.extractall(bundle_dir)
    manifest = load_json(bundle_dir / "manifest.json")
    assert manifest["version"] == package_version()
    seed_environment(bundle_dir)
    unpacked_s = time.monotonic() - started
    settings = {"memory_dir": str(tmp_path / "memory"), "scene": "household", "viewer_port": "0"}
    settings["confirm_actions"] = "true"  # and this client cannot ask its user (no elicitation)
    config = manifest["server"]["mcp_config"]
    command = [substitute(a, bundle_dir, settings) for a in [config["command"], *config["args"]]]
    env = {"PATH": f"{Path(uv).parent}{os.pathsep}/usr/bin{os.pathsep}/bin", "UV_OFFLINE": "1"}
    env |= {k: substitute(v, bundle_dir, settings) for k, v in config.get("env", {}).items()}
    log = tmp_path / "server.log"
    with log.open("wb") as errors:
        proc = subprocess.Popen(command, cwd="/", env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=errors)
        try:
            try:
                init = rpc(
                    proc,
                    {
                        "jsonrpc": "2.0",
                        "id": 1,
                        "method": "initialize",
                        "params": {
                            "protocolVersion": "2025-06-18",
                            "capabilities": {},
                            "clientInfo": {"name": "bundle-test", "version": "0"},
                        },
                    },
                    timeout_s=180,
                )
                rpc(proc, {"jsonrpc": "2.0", "method": "notifications/initialized"}, timeout_s=5)
                tools = rpc(proc, {"jsonrpc": "2.0", "id": 2, "method": "tools/list"}, timeout_s=60)
                listed_s = time.monotonic() - started - unpacked_s
                call = {"name": "move_to", "arguments": {"location": "Kitchen Door"}}
                moved = rpc(proc, {"jsonrpc": "2.0", "id": 3, "method": "tools/call", "params": call}, timeout_s=60)
            except AssertionError:
                text = log.read_text(errors="replace")
                hint = " (the bundle is stale: `make bundle`)" if "Network connectivity is disabled" in text else ""
                raise AssertionError(f"the bundle did not start{hint}:\n{text[-3000:]}") from None
        finally:
            if proc.stdin is not None:
                proc.stdin.close()
            proc.terminate()
            proc.wait(timeout=30)
            # The seeded environment shares its files with this virtualenv: leave no copy behind.
            shutil.rmtree(bundle_dir / ".venv", ignore_errors=True)
    assert init is not None and init["result"]["serverInfo"]["name"] == "robocog"
    assert tools is not None and {t["name"] for t in tools["result"]["tools"]} == ROBOT_TOOLS | APP_TOOLS
    # The consent error speaks of the extension's setting, by its title, never of a flag the user never typed.
    assert moved is not None and moved["result"]["isError"]
    refusal = moved["result"]["content"][0]["text"]
    assert f"'{manifest['user_config']['confirm_actions']['title']}' off in the extension's settings" in refusal
    assert "--confirm-actions" not in refusal
    print(f"bundle {BUNDLE.stat().st_size / 1e6:.2f} MB; unpacked and seeded in {unpacked_s:.1f} s; ", end="")
    print(f"installed and listed its tools in {listed_s:.1f} s")


@pytest.mark.anyio
async def test_robocog_serve_starts_the_server_a_registry_host_runs(tmp_path: Path) -> None:
    """server.json's package runs `robocog serve`: the same server as robocog-server, over stdio."""
    import tempfile as _tempfile

    from mcp import Client
    from mcp.client.stdio import StdioServerParameters, stdio_client

    robocog = Path(sys.executable).parent / "robocog"
    params = StdioServerParameters(
        command=str(robocog), args=["serve", "--data-dir", str(tmp_path)], env={"ANONYMIZED_TELEMETRY": "False"}
    )
    async with Client(stdio_client(params, errlog=_tempfile.TemporaryFile("w+"))) as client:
        names = {tool.name for tool in (await client.list_tools()).tools}
    assert names == ROBOT_TOOLS | APP_TOOLS
