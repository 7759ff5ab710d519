"""Episodic memory (ChromaDB) and the per-episode scratchpad (no MCP code)."""
