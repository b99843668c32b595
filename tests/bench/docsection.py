"""docsection.py — the one way the bench scripts write their part of
docs/benchmarks.md: a block between <!-- TAG:begin ... --> and
<!-- TAG:end --> markers, replaced in place or appended at the end."""
import os
import re


def write_section(doc, tag, lines):
    """Replaces (or appends) the TAG block of the Markdown file doc with lines;
    lines[0] must be the begin marker and lines[-1] the end marker."""
    text = open(doc).read() if os.path.exists(doc) else ""
    block = "\n".join(lines) + "\n"
    pat = r"<!-- %s:begin.*?<!-- %s:end -->\n?" % (tag, tag)
    if "<!-- %s:begin" % tag in text:
        text = re.sub(pat, lambda m: block, text, flags=re.S)
    else:
        text = text.rstrip("\n") + "\n\n" + block
    with open(doc, "w") as f:
        f.write(text)
