"""The suite generator: families drawn into instances (`generator`), fresh splits from a seed (`seeded`)."""

from __future__ import annotations


def generate_on_demand() -> None:
    """Let `robocog.shared.suite.load_split` generate a fresh split ("test@12345") missing from the cache
    with this package's generator, imported only when one is generated (robocog's commands and the
    Inspect tasks call this; the server never generates)."""
    from pathlib import Path

    from robocog.shared.seeded_splits import use_generator

    def generate(suite: str, split: str, seed: int, root: Path) -> Path:
        from robocog.agent.suitegen.seeded import generate_into

        return generate_into(suite, split, seed, root)

    use_generator(generate)
