"""The client side of robocog: the LiteLLM agent loop over MCP, the scripted planner, evaluation, reports."""

import os

# LiteLLM fetches its model cost map over the network at import unless told to use its local copy;
# every robocog.agent import runs this first. Chroma's telemetry stays off as well.
os.environ.setdefault("LITELLM_LOCAL_MODEL_COST_MAP", "True")
os.environ.setdefault("ANONYMIZED_TELEMETRY", "False")
