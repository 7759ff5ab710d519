"""Data the world loads: scenes, tasks, the robot description, the embedding vocabulary."""

from pathlib import Path

ASSETS_DIR = Path(__file__).resolve().parent
