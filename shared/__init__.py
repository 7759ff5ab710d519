"""What the server and the client both import: pydantic schemas of tool results, tasks and traces."""
