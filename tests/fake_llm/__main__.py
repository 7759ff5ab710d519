"""``python -m tests.fake_llm --port 8765``: serve the scripted planner on all routes, for trying the
CLI by hand."""

from __future__ import annotations

import contextlib
import threading

from tests.fake_llm.scripts import planner_script
from tests.fake_llm.server import FakeLLM


def main() -> None:
    """Serve until interrupted, printing the model and api base of each route."""
    import argparse

    parser = argparse.ArgumentParser(
        description="Serve the scripted planner over the OpenAI, Anthropic and Ollama APIs."
    )
    parser.add_argument("--port", type=int, default=8765)
    parser.add_argument("--variant", default="planner", choices=["planner", "overconfident", "refuser"])
    args = parser.parse_args()
    with FakeLLM(planner_script(args.variant), port=args.port) as server:
        print(f"openai:    --model openai/fake --api-base {server.openai_base}")
        print(f"anthropic: --model anthropic/fake --api-base {server.anthropic_base}")
        print(f"ollama:    --model ollama_chat/fake --api-base {server.ollama_base}", flush=True)
        with contextlib.suppress(KeyboardInterrupt):
            threading.Event().wait()


if __name__ == "__main__":
    main()
