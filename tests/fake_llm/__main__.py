"""``python -m tests.fake_llm --port 8765``: serve the scripted planner on all routes, for trying the
CLI by hand; ``--llama-cpp`` behind a llama.cpp server's edges (`tests.fake_llm.llama_cpp`)."""

from __future__ import annotations

import contextlib
import threading

from tests.fake_llm.llama_cpp import llama_cpp
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
    parser.add_argument(
        "--llama-cpp",
        action="store_true",
        help="answer as a llama.cpp server does: tools dropped without tool_choice, a 500 on content: null",
    )
    args = parser.parse_args()
    script = planner_script(args.variant)
    with FakeLLM(llama_cpp(script) if args.llama_cpp else script, port=args.port) as server:
        print(f"openai:    --model openai/fake --api-base {server.openai_base}")
        print(f"anthropic: --model anthropic/fake --api-base {server.anthropic_base}")
        print(f"ollama:    --model ollama_chat/fake --api-base {server.ollama_base}", flush=True)
        with contextlib.suppress(KeyboardInterrupt):
            threading.Event().wait()


if __name__ == "__main__":
    main()
