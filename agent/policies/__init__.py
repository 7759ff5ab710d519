"""The scripted policies: the planner and its belief, and the offline models built on them."""

#: The model strings answered in-process (`offline`), never by a provider through LiteLLM.
OFFLINE_PREFIXES = ("scripted/", "replay/")


def is_offline(model: str) -> bool:
    """Whether `model` is one of the offline models (`scripted/...`, `replay/...`)."""
    return model.startswith(OFFLINE_PREFIXES)
