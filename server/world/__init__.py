"""The simulated household: scene, robot, navigation and ground truth (no MCP code)."""
