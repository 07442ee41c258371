"""reslicing."""
