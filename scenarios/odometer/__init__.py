"""The odometer scenario: :mod:`.scenario` runs it, :mod:`.figures` draws it; README.md here says what it
reproduces, its sources, settings and measured results."""
