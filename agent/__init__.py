"""The client side of robocog: the LiteLLM agent loop over MCP, the scripted planner, evaluation, reports."""
