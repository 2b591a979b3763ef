"""tests/check_offline.py finds the resources a built page would load from another host."""

from __future__ import annotations

from tests.check_offline import is_remote, main, remote_resources


def test_is_remote():
    assert is_remote("https://cdn.jsdelivr.net/npm/mathjax@3/es5/tex-chtml.js")
    assert is_remote("//cdn.example.org/x.js")
    assert not is_remote("_static/mathjax/tex-chtml.js")
    assert not is_remote("../_static/pygments.css?v=1")
    assert not is_remote("data:image/png;base64,AAAA")


def test_remote_script_and_stylesheet_found(tmp_path):
    (tmp_path / "sub").mkdir()
    (tmp_path / "index.html").write_text(
        '<html><head><script src="_static/local.js"></script>'
        '<script defer src="https://cdn.jsdelivr.net/npm/mathjax@3/es5/tex-chtml.js"></script>'
        '<link rel="canonical" href="https://example.org/index.html">'
        '</head><body><a href="https://numpy.org/doc/stable/">numpy</a></body></html>', encoding="utf-8")
    (tmp_path / "sub" / "page.html").write_text(
        '<link rel="stylesheet" href="//fonts.example.org/font.css"/><img src="../x.png" alt="x">', encoding="utf-8")
    found = remote_resources(tmp_path)
    assert found == ["index.html:1: <script> https://cdn.jsdelivr.net/npm/mathjax@3/es5/tex-chtml.js",
                     "sub/page.html:1: <link> //fonts.example.org/font.css"]
    assert main([str(tmp_path)]) == 1


def test_local_site_passes(tmp_path):
    (tmp_path / "index.html").write_text('<script src="_static/mathjax/tex-chtml.js"></script>', encoding="utf-8")
    assert remote_resources(tmp_path) == []
    assert main([str(tmp_path)]) == 0


def test_remote_font_in_stylesheet_found(tmp_path):
    (tmp_path / "theme.css").write_text('@import "../basic.css";\n'
                                        'body { src: url("https://fonts.example.org/a.woff2"); }\n'
                                        '.x { background: url(data:image/png;base64,AAAA); }\n', encoding="utf-8")
    assert remote_resources(tmp_path) == ["theme.css:2: <css> https://fonts.example.org/a.woff2"]
