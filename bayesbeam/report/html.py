"""HTML pieces of the self-contained reports (comparison, diagnosis): page, headings, tables, figures.

Figures are PNGs embedded as base64 data and the CSS is inline, so a page opens anywhere without a
network. A small inline script records on ``<body data-figures-loaded="ok/total">`` how many
images decoded, so a headless browser can check every figure.
"""
from __future__ import annotations

import base64
import html

from bayesbeam.report.plots import png_bytes

STYLE = """
body { font: 15px/1.45 system-ui, sans-serif; color: #222; max-width: 1000px; margin: 0 auto; padding: 0 16px 48px; }
h1 { font-size: 1.5em; margin-bottom: 0.2em; } h2 { border-bottom: 1px solid #ccc; margin-top: 1.8em; }
nav a { margin-right: 1em; } .meta { color: #666; font-size: 0.9em; }
.verdict { font-size: 1.08em; background: #eef4fb; border-left: 4px solid #3a78c2; padding: 10px 14px; }
table { border-collapse: collapse; margin: 10px 0 16px; font-size: 0.88em; }
th, td { border: 1px solid #ccc; padding: 3px 7px; text-align: right; vertical-align: top; }
th { background: #f3f3f3; } .text { text-align: left; }
th small { display: block; font-weight: normal; color: #555; max-width: 16em; text-align: left; }
.bad { background: #f8d0d0; font-weight: 600; } .best { background: #e3f2e3; }
figure { margin: 12px 0 20px; } figure img { max-width: 100%; height: auto; display: block; }
figcaption { font-size: 0.88em; color: #444; }
.grid { display: flex; flex-wrap: wrap; align-items: flex-end; gap: 0 24px; } ul.caveats li { margin-bottom: 4px; }
"""

SCRIPT = """
window.addEventListener("load", function () {
  var images = Array.prototype.slice.call(document.images);
  var ok = images.filter(function (img) { return img.complete && img.naturalWidth > 0; }).length;
  document.body.dataset.figuresLoaded = ok + "/" + images.length;
});
"""


def page(title, body) -> str:
    """The whole HTML document: ``title`` (plain text) and the body's already-escaped HTML parts."""
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">"
            f"<title>{esc(title)}</title><style>{STYLE}</style>"
            f"<script>{SCRIPT}</script></head>\n<body>\n" + "\n".join(body) + "\n</body></html>\n")


def nav(sections) -> str:
    """Links to the ``(anchor, title)`` sections."""
    return "<nav>" + " ".join(f'<a href="#{a}">{t}</a>' for a, t in sections) + "</nav>"


def h2(anchor, sections) -> str:
    """The heading of the section ``anchor`` of ``sections`` ((anchor, title) pairs)."""
    return f'<h2 id="{anchor}">{dict(sections)[anchor]}</h2>'


def table(head, rows, text_columns=1, highlight_first=False) -> str:
    """A table of already-escaped HTML cells: text left-aligned (the first ``text_columns`` columns, or
    the columns of that index collection), numbers right; ``highlight_first`` marks the first row (the
    best model)."""
    left = set(range(text_columns)) if isinstance(text_columns, int) else set(text_columns)

    def cells(tag, row):
        return "".join(f'<{tag} class="text">{c}</{tag}>' if j in left else f"<{tag}>{c}</{tag}>"
                       for j, c in enumerate(row))

    out = [f"<table><thead><tr>{cells('th', head)}</tr></thead><tbody>"]
    for i, row in enumerate(rows):
        cls = ' class="best"' if highlight_first and i == 0 else ""
        out.append(f"<tr{cls}>{cells('td', row)}</tr>")
    return "".join(out) + "</tbody></table>"


def figure(fig, alt, caption) -> str:
    """``fig`` (closed here) as an embedded PNG with its alt text and caption (plain text)."""
    data = base64.b64encode(png_bytes(fig)).decode("ascii")
    cap = f"<figcaption>{esc(caption)}</figcaption>" if caption else ""
    return f'<figure><img alt="{esc(alt)}" src="data:image/png;base64,{data}">{cap}</figure>'


def flag(text, bad) -> str:
    """``text`` highlighted when ``bad``."""
    return f'<span class="bad">{text}</span>' if bad else text


def esc(text) -> str:
    return html.escape(str(text))


def number(value, fmt) -> str:
    return "n/a" if value is None else f"{value:{fmt}}"
