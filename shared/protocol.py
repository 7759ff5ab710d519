"""Names both sides of the MCP connection agree on, beyond the tools' own schemas."""

#: `_meta` key a client sets on tool calls to name the model driving the robot; end_task stores it.
MODEL_META_KEY = "robocog/model"

#: The eval profile's controls for harnesses: a client never offers them to the model it drives.
CONTROL_TOOLS = frozenset({"reset_world", "begin_task", "check_task", "clear_memory"})

#: The version of the published MCP contract (assets/contract/, CHANGELOG.md there). The server announces
#: it in its instructions as "MCP contract X.Y"; `robocog contract` reads it back from there.
CONTRACT_VERSION = "1.0"
