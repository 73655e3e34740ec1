"""``neuronav report``: one self-contained HTML page of a run, compare or sweep folder.

loader (read a folder) -> tables (settings, versions, statistics) and replay (a trial's time slider
over path, world, senses and brain) -> html (the page).
"""

from neuronav.runs.report.html import write_report

__all__ = ["write_report"]
