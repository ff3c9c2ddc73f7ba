r"""MkDocs hooks for the docs site (``mkdocs.yml``: ``hooks``).

- The user guide (``docs/user-guide.md``) is the site's front page: it keeps its file
  name, so links between the pages (and on GitHub) stay as they are; only its address
  in the built site becomes the root (``index.html``).
- A page may link to a module's source (``[fits/errmodel.py](../fits/errmodel.py)``),
  which works when reading the files in the repository. The site has no sources, so such
  a link becomes a link to the module's API reference (a cross-reference that
  mkdocstrings resolves, and that fails the strict build if the module is not
  documented).
- In a table, GitHub needs a pipe inside inline code escaped (`` `a\|b` ``), while
  Python-Markdown keeps the backslash there and already leaves pipes in code alone: the
  escape is dropped for the site.
"""

import re

FRONT_PAGE = "user-guide.md"
_SOURCE_LINK = re.compile(r"\]\((?:\.\./)+((?:fits|vidtrack|calibration)(?:/\w+)*)\.py\)")
_CODE_SPAN = re.compile(r"`[^`\n]*`")


def on_files(files, config):
    page = files.get_file_from_path(FRONT_PAGE)
    if page is not None:
        page.dest_uri = "index.html"
        page.url = "./" if config.use_directory_urls else "index.html"
    return files


def _module(path):
    parts = path.split("/")
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _unescape_table_code(line):
    if not line.lstrip().startswith("|"):
        return line
    return _CODE_SPAN.sub(lambda m: m.group(0).replace("\\|", "|"), line)


def on_page_markdown(markdown, page, config, files):
    markdown = _SOURCE_LINK.sub(lambda m: f"][{_module(m.group(1))}]", markdown)
    return "\n".join(_unescape_table_code(line) for line in markdown.split("\n"))
