"""The transports the server speaks MCP over: streamable HTTP (its limits, its auth) and stdio."""
