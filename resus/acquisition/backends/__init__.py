"""acquisition/backends."""
