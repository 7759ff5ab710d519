"""A model's name and key checked before LiteLLM is imported (its import costs seconds, 4 s on a quiet
machine and 16 s under load, against a fraction of one for `robocog --help`).

`quick_verdict` reads the cost map LiteLLM itself routes bare names by (the JSON file it ships and
loads with `LITELLM_LOCAL_MODEL_COST_MAP=True`), with the providers it names, and the key variables of
the common cloud providers. It refuses a model LiteLLM would refuse (a typo such as `gpt4o`, a cloud
model whose key is not set) in the same words, accepts one it is sure of, and leaves everything else
to LiteLLM (`None`): a provider it does not know the key of, a `provider/model` whose provider is not in
the map. A test holds its verdicts equal to LiteLLM's.
"""

from __future__ import annotations

import difflib
import importlib.util
import json
import os
from functools import cache
from pathlib import Path
from typing import Any, Literal

#: The one environment variable each of these providers needs (LiteLLM's `validate_environment`).
KEY_VARIABLES: dict[str, str] = {
    "openai": "OPENAI_API_KEY",
    "anthropic": "ANTHROPIC_API_KEY",
    "mistral": "MISTRAL_API_KEY",
    "groq": "GROQ_API_KEY",
    "deepseek": "DEEPSEEK_API_KEY",
    "xai": "XAI_API_KEY",
    "cohere": "COHERE_API_KEY",
    "openrouter": "OPENROUTER_API_KEY",
    "together_ai": "TOGETHERAI_API_KEY",
    "fireworks_ai": "FIREWORKS_AI_API_KEY",
    "perplexity": "PERPLEXITYAI_API_KEY",
}
#: Providers that need no key (robocog's offline models, Ollama): `robocog.agent.client.model.KEYLESS_ROUTES`.
KEYLESS = frozenset({"scripted", "replay", "ollama", "ollama_chat"})
#: The cost map's file inside the LiteLLM package.
_COST_MAP = "model_prices_and_context_window_backup.json"


@cache
def cost_map() -> dict[str, Any] | None:
    """LiteLLM's local cost map (model name -> its entry), read without importing LiteLLM; None when
    LiteLLM or the file cannot be found."""
    spec = importlib.util.find_spec("litellm")
    if spec is None or spec.origin is None:
        return None
    try:
        data = json.loads((Path(spec.origin).parent / _COST_MAP).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def unknown_model(model: str, names: list[str]) -> str:
    """The one line for a model LiteLLM does not know (with the closest bare name in its map)."""
    closest = difflib.get_close_matches(model, names, n=1, cutoff=0.6)
    hint = f"; did you mean {closest[0]}?" if closest else ""
    return (
        f"--model {model}: LiteLLM does not know this model or its provider{hint} (name the provider, "
        "e.g. openai/gpt-4o, ollama/qwen3, or give --api-base for an OpenAI-compatible server)"
    )


def missing_key(model: str, variables: list[str]) -> str:
    """The one line for a cloud model whose key is not set."""
    return f"model {model!r} needs {', '.join(variables)} set in the environment (or give --api-key)"


#: What `quick_verdict` can tell: LiteLLM would take the model; does not know it; lacks its key; or
#: only LiteLLM can tell.
Verdict = Literal["ok", "unknown", "no_key", "ask_litellm"]


def quick_verdict(model: str, api_key: str | None = None) -> tuple[Verdict, str]:
    """What LiteLLM would say of `model` (and its key, unless `api_key` is given), with the one line for a
    refusal: ("unknown", why) for a model it does not know, ("no_key", why) for a cloud model whose key
    is not set, ("ok", "") when it would take it, ("ask_litellm", "") when only LiteLLM can tell."""
    entries = cost_map()
    if entries is None:
        return "ask_litellm", ""
    providers = {str(v.get("litellm_provider")) for v in entries.values() if isinstance(v, dict)}
    prefix, slash, _ = model.partition("/")
    if slash and (prefix in providers or prefix in KEYLESS):
        provider = prefix
    elif isinstance(entries.get(model), dict) and entries[model].get("litellm_provider"):
        provider = str(entries[model]["litellm_provider"])
    elif slash:
        return "ask_litellm", ""  # a provider the map does not name: LiteLLM's own list may
    else:
        return "unknown", unknown_model(model, [n for n in entries if "/" not in n])
    if api_key or provider in KEYLESS:
        return "ok", ""
    variable = KEY_VARIABLES.get(provider)
    if variable is None:
        return "ask_litellm", ""
    if not os.environ.get(variable):
        return "no_key", missing_key(model, [variable])
    return "ok", ""
