"""``python -m vigen.losses``: the table of every algorithm's record, as ``docs/losses.md`` holds it."""

from vigen.losses.paper_defaults import defaults_markdown

print(defaults_markdown(), end="")
