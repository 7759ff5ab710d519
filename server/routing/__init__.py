"""The router: one address in front of several fleet processes (`robocog-server --processes N`)."""
