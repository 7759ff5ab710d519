"""The MCP server side of robocog: the PyBullet world, the memory and the MCP wiring."""
