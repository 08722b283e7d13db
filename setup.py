"""The compiled part of the build; everything else is declared in pyproject.toml.

``shipradar._frames`` (``shipradar/_frames.c``: the stream's per-message byte work) is an
optional extension: where no C compiler or no Python headers are found, setuptools warns
that it could not build it and the install goes on with the pure-Python encoder
(``shipradar/_frames_py.py``, the same bytes, slower: docs/performance.md section 15;
``shipradar._framing`` chooses at import). It is declared here rather than under
``[tool.setuptools] ext-modules``, which setuptools still calls experimental.
"""

from setuptools import Extension, setup

setup(ext_modules=[
    Extension("shipradar._frames", sources=["shipradar/_frames.c"], extra_compile_args=["-O2"],
              optional=True),
])
