"""World content: the scenes the visual scenarios are set in (see README.md here for their sources)."""
