"""The browser app: ``grubler app`` serves one page that edits, animates and plots a scene.

``actions`` is what each request does, in the library's terms (a scene as the
parsed TOML the CLI reads, checked by the same functions); ``server`` is the
HTTP side: the local-only listener, the Host and Origin checks, the per-browser
sessions and cancellable runs; ``static/`` holds the page (plain HTML, JS and
SVG, nothing to build).

May import every layer below the front one (the public API, mechanism, views,
system, studies, controllers); only ``grubler.cli`` imports it.
"""
