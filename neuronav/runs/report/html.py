"""Assemble the report page: one self-contained HTML file for one or several result folders.

The page holds plotly.js once (inline, so it opens from disk with no network), the tables of
:mod:`~neuronav.runs.report.tables`, every figure PNG as a data URI, the run's MP4s as ``<video>``
elements pointing at the files next to the page's folders (relative paths), and per recorded trial
a replay (:mod:`~neuronav.runs.report.replay`). A replay's figure is stored as JSON in the page and
drawn when its trial is opened (the first is open), so a run with many recorded trials loads fast.
The only hand-written script is that glue, and the sync of trial 0's video with its slider.
"""

from __future__ import annotations

import base64
import html
import os
from pathlib import Path

from neuronav.errors import ConfigError
from neuronav.runs.report import replay, tables
from neuronav.runs.report.loader import RunFolder, load

MAX_REPLAYS = 20
"""Replays per run folder at most (the trials with recorded time series, in trial order)."""

STYLE = """
body{font-family:system-ui,sans-serif;margin:1.2em;color:#222}
h1{font-size:1.5em} h2{font-size:1.25em;border-bottom:1px solid #ccc} h3{font-size:1.05em}
table{border-collapse:collapse;font-size:0.82em;margin:0.4em 0 1em}
td,th{border:1px solid #ddd;padding:2px 6px;text-align:left;vertical-align:top}
th{background:#f3f3f3} .note{color:#a33}
.columns{display:flex;gap:1.5em;align-items:flex-start;overflow-x:auto}
.columns>section{flex:1 1 0;min-width:560px}
figure{display:inline-block;margin:0.3em;max-width:100%} figure img{max-width:100%;border:1px solid #eee}
figcaption{font-size:0.8em;color:#555} details{margin:0.4em 0} summary{cursor:pointer;font-weight:600}
video{max-width:100%} .imagelayer image{image-rendering:pixelated}
"""

# Glue: draw a replay when its trial is opened; move trial 0's video with its slider (and the slider
# with the video). Plotly has no feature for either.
GLUE = """
function neuronavDraw(details){
  var div=details.querySelector('.replay'); if(!div||div.dataset.drawn)return;
  var fig=JSON.parse(document.getElementById(div.dataset.figure).textContent); div.dataset.drawn='1';
  Plotly.newPlot(div,{data:fig.data,layout:fig.layout,frames:fig.frames,config:{responsive:true}}).then(function(){
    var video=div.dataset.video&&document.getElementById(div.dataset.video); if(!video)return;
    var times=fig.layout.meta.frame_times, end=times[times.length-1]||1, own=false;
    function seek(i){var t=times[i]/end*(video.duration||end);
      if(Math.abs(video.currentTime-t)>0.25)video.currentTime=t;}
    div.on('plotly_animatingframe',function(e){if(!own)seek(parseInt(e.name));});
    video.addEventListener('timeupdate',function(){if(video.paused)return;
      var f=video.currentTime/(video.duration||end)*end, i=0; while(i<times.length-1&&times[i+1]<=f)i++;
      own=true; Plotly.animate(div,[String(i)],{mode:'immediate',frame:{duration:0,redraw:false},
        transition:{duration:0}}).then(function(){own=false;});});
  });
}
function neuronavDrawShown(){  // every open trial whose folds are all open (drawn at its real size)
  // An open fold's toggle comes while the page is parsed, before its figure's data is all there: wait for it.
  if(document.readyState==='loading')return;
  document.querySelectorAll('details.trial[open] .replay').forEach(function(div){
    if(div.checkVisibility?div.checkVisibility():div.offsetParent!==null)neuronavDraw(div.closest('details'));});
}
document.addEventListener('DOMContentLoaded',neuronavDrawShown);
document.addEventListener('toggle',neuronavDrawShown,true);  // toggle does not bubble: listen while capturing
"""


PAGE_START = "<!DOCTYPE html><html><head><meta charset='utf-8'><meta name='generator' content='neuronav report'>"
"""How every report begins: a file that does not is not overwritten (a report writes only over its own)."""


def default_out(paths: list[Path]) -> Path:
    """Where the report goes without ``--out``: ``report.html`` in the folder (several: the current folder)."""
    return Path(paths[0]) / "report.html" if len(paths) == 1 else Path("report.html")


def write_report(paths: list[str | Path], out: str | Path | None = None, max_replays: int = MAX_REPLAYS) -> Path:
    """Write the report of the run, compare or sweep folders ``paths`` to ``out``; return its path.

    Raises
    ------
    ConfigError
        No folder given, a folder that is not a result folder (:func:`~neuronav.runs.report.loader.load`),
        or an ``out`` whose folder does not exist or may not be written.
    """
    if not paths:
        raise ConfigError("report: give at least one folder written by neuronav run, compare or sweep")
    folders = [load(p) for p in paths]
    target = Path(out) if out is not None else default_out([Path(p) for p in paths])
    if target.is_dir():
        target = target / "report.html"
    _check_writable(target)
    page = render(folders, target.parent, max_replays)
    from neuronav.runs.rundir import write_atomic

    try:
        write_atomic(target, page)
    except OSError as error:
        raise ConfigError(f"report: cannot write {str(target)!r} ({error.strerror or error})") from None
    return target


def render(folders: list[RunFolder], page_dir: Path, max_replays: int = MAX_REPLAYS) -> str:
    """The page's HTML for ``folders``; links (videos) are relative to ``page_dir``."""
    from plotly.offline import get_plotlyjs

    builder = _Page(page_dir, max_replays)
    if len(folders) == 1:
        body = builder.folder(folders[0], level=2)
    else:
        runs = [child for f in folders for child in (f.children or [f])]
        body = ("<h2>comparison</h2>" + tables.metrics_side_by_side(runs) + "<div class='columns'>"
                + "".join(f"<section>{builder.folder(f, level=2)}</section>" for f in folders) + "</div>")
    names = ", ".join(f.label for f in folders)
    first = folders[0].summary
    title = f"neuronav report: {first.get('scenario', '')} ({names})"
    return (f"{PAGE_START}<title>{html.escape(title)}</title>"
            f"<style>{STYLE}</style><script type='text/javascript'>{get_plotlyjs()}</script>"
            f"<script type='text/javascript'>{GLUE}</script></head><body><h1>{html.escape(title)}</h1>"
            f"{body}{''.join(builder.figures)}</body></html>")


class _Page:
    """Builds the sections of one page; collects the replays' JSON (one ``<script>`` each)."""

    def __init__(self, page_dir: Path, max_replays: int) -> None:
        self.page_dir = Path(page_dir)
        self.max_replays = max_replays
        self.figures: list[str] = []

    def folder(self, folder: RunFolder, level: int) -> str:
        if folder.kind == "compare":
            return self.compare(folder, level)
        if folder.kind == "sweep":
            return self.sweep(folder, level)
        return self.run(folder, level)

    def run(self, run: RunFolder, level: int) -> str:
        h, sub = f"h{level}", f"h{min(level + 1, 6)}"
        parts = [f"<{h}>{html.escape(run.label)}: {html.escape(str(run.summary.get('scenario', '')))} on "
                 f"{html.escape(str(run.summary.get('backend', '')))}</{h}>", tables.run_facts(run),
                 f"<{sub}>metrics</{sub}>", tables.metrics(run),
                 f"<details open><summary>summary statistics</summary>{tables.summary_statistics(run)}</details>"]
        comparisons = tables.comparisons(run)
        if comparisons:
            parts += [f"<{sub}>comparisons</{sub}>", comparisons]
        parts += [f"<details><summary>settings</summary>{tables.settings(run)}</details>",
                  f"<details><summary>versions</summary>{tables.versions(run)}</details>"]
        if run.figures:
            parts += [f"<{sub}>figures</{sub}>", self.images(run)]
        videos = self.videos(run)
        if videos:
            parts += [f"<{sub}>video</{sub}>", videos]
        parts.append(self.replays(run, sub))
        return "".join(parts)

    def compare(self, folder: RunFolder, level: int) -> str:
        h, sub = f"h{level}", f"h{min(level + 1, 6)}"
        parts = [f"<{h}>{html.escape(folder.label)}: compare {html.escape(str(folder.summary.get('scenario', '')))}"
                 f" on {html.escape(', '.join(c.label for c in folder.children))}</{h}>",
                 f"<{sub}>metrics by backend</{sub}>", tables.metrics_side_by_side(folder.children)]
        between = tables.across_backends(folder)
        if between:
            parts += [f"<{sub}>between backends</{sub}>", between]
        if folder.figures:
            parts.append(self.images(folder))
        parts.append("<div class='columns'>" + "".join(
            f"<section>{self.run(child, min(level + 1, 6))}</section>" for child in folder.children) + "</div>")
        return "".join(parts)

    def sweep(self, folder: RunFolder, level: int) -> str:
        h, sub = f"h{level}", f"h{min(level + 1, 6)}"
        grid = folder.summary.get("grid") or {}
        parts = [f"<{h}>{html.escape(folder.label)}: sweep of {html.escape(str(folder.summary.get('scenario', '')))}"
                 f" over {html.escape(', '.join(map(str, grid)))}</{h}>", tables.run_facts(folder),
                 f"<{sub}>metrics by grid point</{sub}>", tables.metrics_side_by_side(folder.children)]
        comparisons = tables.comparisons(folder)
        if comparisons:
            parts += [f"<{sub}>comparisons between grid points</{sub}>", comparisons]
        parts.append(f"<details><summary>settings</summary>{tables.settings(folder)}</details>")
        if folder.figures:
            parts.append(self.images(folder))
        for child in folder.children:
            parts.append(f"<details><summary>grid point {html.escape(child.label)}</summary>"
                         f"{self.run(child, min(level + 1, 6))}</details>")
        return "".join(parts)

    def images(self, run: RunFolder) -> str:
        out = []
        for path in run.figures:
            data = base64.b64encode(path.read_bytes()).decode("ascii")
            out.append(f"<figure><img alt='{html.escape(path.name)}' src='data:image/png;base64,{data}'>"
                       f"<figcaption>{html.escape(path.name)}</figcaption></figure>")
        return "".join(out)

    def videos(self, run: RunFolder) -> str:
        out = []
        for path in run.videos:
            relative = Path(os.path.relpath(path.resolve(), self.page_dir.resolve())).as_posix()
            out.append(f"<figure><video id='{self._id('video')}' controls preload='metadata' "
                       f"src='{html.escape(relative)}'></video><figcaption>{html.escape(path.name)} "
                       f"(moves with trial 0's slider)</figcaption></figure>")
        return "".join(out)

    def replays(self, run: RunFolder, sub: str) -> str:
        import plotly.io

        series = run.series()
        trials = replay.replay_trials(series)
        if not trials:
            return f"<{sub}>replay</{sub}><p>no trial recorded a path; nothing to replay</p>"
        shown = trials[: self.max_replays]
        more = (f" (the first {len(shown)} of {len(trials)} recorded)" if len(trials) > len(shown) else
                f" ({len(shown)} recorded of {run.summary.get('trials', len(shown))} trials)")
        parts = [f"<{sub}>replay{html.escape(more)}</{sub}>"]
        video_id = self._last_video if run.videos else ""
        config = run.summary.get("config") or {}
        for n, trial in enumerate(shown):
            try:
                data = replay.trial_data(series, trial, config)
            except ValueError as error:
                parts.append(f"<p class='note'>trial {trial}: {html.escape(str(error))}</p>")
                continue
            fig = replay.figure(data, title=f"{run.label}: trial {trial}")
            fig_id = self._id("figure")
            self.figures.append(f"<script type='application/json' id='{fig_id}'>"
                                f"{_script_safe(plotly.io.to_json(fig, validate=False))}</script>")
            video = f" data-video='{video_id}'" if trial == 0 and video_id else ""
            parts.append(f"<details class='trial'{' open' if n == 0 else ''}><summary>trial {trial}</summary>"
                         f"<div class='replay' id='{self._id('replay')}' data-figure='{fig_id}'{video}></div>"
                         "</details>")
        return "".join(parts)

    _count = 0
    _last_video = ""

    def _id(self, kind: str) -> str:
        self._count += 1
        name = f"{kind}-{self._count}"
        if kind == "video":
            self._last_video = name
        return name


def _script_safe(text: str) -> str:
    """JSON that cannot end its ``<script>`` element early."""
    return text.replace("</", "<\\/")


def _check_writable(target: Path) -> None:
    parent = target.parent if str(target.parent) else Path(".")
    if not parent.is_dir():
        raise ConfigError(f"report: cannot write {str(target)!r}: folder {str(parent)!r} does not exist")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise ConfigError(f"report: cannot write {str(target)!r}: folder {str(parent)!r} is not writable")
    if target.is_symlink() or (target.exists() and not target.is_file()):
        raise ConfigError(f"report: will not write over {str(target)!r}: it is not a regular file")
    if target.exists():
        if not os.access(target, os.W_OK):
            raise ConfigError(f"report: cannot write {str(target)!r}: the file is not writable")
        with open(target, "rb") as stream:
            start = stream.read(len(PAGE_START.encode()))
        if start != PAGE_START.encode():
            raise ConfigError(f"report: will not write over {str(target)!r}: it is not a report neuronav wrote "
                              "(give another --out, or remove the file)")
