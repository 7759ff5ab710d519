"""A model's name and key checked without LiteLLM (robocog.agent.client.model_names) say what LiteLLM
itself says: the same models unknown, the same keys missing, in the same words; what the quick check
cannot tell is left to LiteLLM."""

from __future__ import annotations

import subprocess
import sys

import pytest

from robocog.agent.client.model_names import KEY_VARIABLES, quick_verdict, unknown_model

MODELS = [
    "gpt4o",
    "gpt-4o",
    "gpt-4o-mini",
    "o1",
    "openai/gpt-4o",
    "openai/made-up",
    "anthropic/claude-sonnet-4-20250514",
    "claude-3-5-sonnet-20240620",
    "claude-made-up",
    "mistral/mistral-large-latest",
    "groq/llama3-8b-8192",
    "deepseek/deepseek-chat",
    "ollama/qwen3",
    "ollama_chat/qwen3",
    "together_ai/meta-llama/Llama-3-8b",
    "meta-llama/Llama-3-8b",
    "hosted_vllm/qwen",
    "foo",
]


def test_the_quick_verdicts_are_litellms(monkeypatch: pytest.MonkeyPatch) -> None:
    import litellm

    from robocog.agent.client.model_errors import missing_keys

    for variable in KEY_VARIABLES.values():
        monkeypatch.delenv(variable, raising=False)
    monkeypatch.setenv("ANTHROPIC_API_KEY", "sk-test")  # one provider's key set, the others' not
    names = [str(n) for n in litellm.model_cost if "/" not in str(n)]
    asked = 0
    for model in MODELS:
        verdict, problem = quick_verdict(model)
        if verdict == "ask_litellm":
            asked += 1
            continue
        try:
            _, provider, *_ = litellm.get_llm_provider(model)
        except Exception:
            provider = None
        if verdict == "unknown":
            assert provider is None, model
            assert problem == unknown_model(model, names), model
            continue
        assert provider is not None, model
        missing = [] if provider in ("ollama", "ollama_chat") else missing_keys(model)
        assert (verdict == "no_key") == bool(missing), (model, missing)
        if missing:
            assert problem == f"model {model!r} needs {', '.join(missing)} set in the environment (or give --api-key)"
    assert asked < len(MODELS) // 3  # most are told without LiteLLM


def test_a_key_given_is_enough(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("OPENAI_API_KEY", raising=False)
    assert quick_verdict("gpt-4o") == (
        "no_key",
        "model 'gpt-4o' needs OPENAI_API_KEY set in the environment (or give --api-key)",
    )
    assert quick_verdict("gpt-4o", api_key="sk-given") == ("ok", "")


def test_the_quick_check_imports_no_litellm() -> None:
    code = (
        "import sys; from robocog.agent.client.model_names import quick_verdict; "
        "print(quick_verdict('gpt4o')[0], 'litellm' in sys.modules)"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.split() == ["unknown", "False"]
