"""What the MCP app registers: the tool handlers, the resources and prompts, the robot app (MCP App)."""
