"""The experiments: world + body + brain + protocol + metrics + figures, registered by id."""
