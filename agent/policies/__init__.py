"""The scripted policies: the planner and its belief, and the offline models built on them."""

import hashlib

#: The model strings answered in-process (`offline`), never by a provider through LiteLLM.
OFFLINE_PREFIXES = ("scripted/", "replay/")


def is_offline(model: str) -> bool:
    """Whether `model` is one of the offline models (`scripted/...`, `replay/...`)."""
    return model.startswith(OFFLINE_PREFIXES)


def model_seed(seed: int, trial: int, iteration: int, task: str) -> int:
    """A seed for the model per attempt (independent draws for stochastic models); the harness gives
    it to every attempt, and `scripted/faulty`'s truth is drawn from it."""
    digest = hashlib.sha256(f"{seed}:{trial}:{iteration}:{task}".encode()).digest()
    return int.from_bytes(digest[:4], "big")
