"""Writers: what a run leaves on disk. They see only a Result (and the scene as metadata)."""
