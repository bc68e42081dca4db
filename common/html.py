"""A self-contained HTML page (report.html): headings, paragraphs, tables and PNG pictures
inlined as data URIs, so the one file can be mailed or archived and opens in any browser.

A short script at its end counts the pictures the browser decoded and says so on the page
(`data-images-decoded` / `data-images` on <body>): a reader sees at once that nothing is
missing, and a test in a headless browser reads the same figures."""
import base64
import html
from pathlib import Path

from common.files import write_text

STYLE = """body{font-family:sans-serif;margin:2em;max-width:75em}
table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #bbb;padding:.25em .6em}
td.num{text-align:right;font-variant-numeric:tabular-nums}.bad{color:#b00;font-weight:bold}
.good{color:#070}img{max-width:100%;border:1px solid #ddd}figure{margin:1em 0}
#images{color:#555}"""

SCRIPT = """<script>
window.addEventListener("load", function () {
  var imgs = document.images, n = 0;
  for (var i = 0; i < imgs.length; i++) if (imgs[i].complete && imgs[i].naturalWidth > 0) n++;
  document.body.dataset.images = imgs.length;
  document.body.dataset.imagesDecoded = n;
  document.getElementById("images").textContent =
    n + " of " + imgs.length + " pictures shown" + (n < imgs.length ? ": some did not load" : "");
});
</script>"""


def heading(text, level=2):
    return f"<h{level}>{html.escape(text)}</h{level}>"


def paragraph(text):
    return f"<p>{html.escape(text)}</p>"


def items(lines):
    return "<ul>" + "".join(f"<li>{html.escape(str(x))}</li>" for x in lines) + "</ul>"


def table(header, rows, table_id=None):
    """Rows of cells: a str, a number (right-aligned), or (text, css class) such as
    ("OUTSIDE", "bad")."""
    def cell(c):
        if isinstance(c, tuple):
            return f'<td class="{c[1]}">{html.escape(str(c[0]))}</td>'
        if isinstance(c, (int, float)):
            return f'<td class="num">{html.escape(str(c))}</td>'
        return f"<td>{html.escape(str(c))}</td>"
    ident = f' id="{table_id}"' if table_id else ""
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(cell(c) for c in row) + "</tr>" for row in rows)
    return f"<table{ident}><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def picture(path, caption):
    """A PNG file inlined (no picture, and a line saying so, when the file is missing)."""
    path = Path(path)
    if not path.is_file():
        return paragraph(f"({caption}: {path.name} was not written)")
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    return (f'<figure><img alt="{html.escape(caption)}" src="data:image/png;base64,{data}">'
            f"<figcaption>{html.escape(caption)}</figcaption></figure>")


def write_page(path, title, blocks):
    """Write the page `title` with the HTML `blocks` (from the functions above) to `path`."""
    text = (f'<!DOCTYPE html><html lang="en"><head><meta charset="utf-8"><title>'
            f"{html.escape(title)}</title><style>{STYLE}</style></head><body>"
            f"{heading(title, 1)}<p id=\"images\"></p>{''.join(blocks)}{SCRIPT}</body></html>\n")
    write_text(path, text)
    return path
