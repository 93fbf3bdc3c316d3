"""The command line of an external renderer: a template with placeholders the harness fills.

``mitsuba-refs check SCENE --command 'TEMPLATE'`` runs ``TEMPLATE`` through ``/bin/sh`` once per
render, each value shell-quoted. The placeholders (:data:`PLACEHOLDERS`):

================  ============================================================================
``{scene}``       the scene file the renderer reads (``--renderer-scene``, else SCENE itself)
``{spp}``         samples per pixel of this render
``{seed}``        its seed, below 2^31: every run of a check has its own, far enough from
                  every other that no seeding scheme shares a stream (:mod:`.seeding`)
``{out}``         where to write the image (a fresh temporary file, ``--output-suffix``)
``{out_variance}`` optional: where to write a second image of per-sample variances
``{width}``       film width in pixels
``{height}``      film height in pixels
``{max_depth}``   longest path (-1: unbounded); when used, the per-bounce localisation runs
``{defines}``     the scene parameters as ``-D name=value ...`` (Mitsuba's and pathtracer's form)
================  ============================================================================

``{{`` and ``}}`` stand for literal braces. Any other name in braces is a usage error.
"""
from __future__ import annotations

import shlex
import string
from dataclasses import dataclass

from ..errors import RefsInputError

#: Placeholder -> what the harness puts there (the ``--help`` text lists them).
PLACEHOLDERS = {
    "scene": "the scene file the renderer reads",
    "spp": "samples per pixel",
    "seed": "seed of this render (< 2^31; runs' seeds are far enough apart to share no stream)",
    "out": "image file to write",
    "out_variance": "optional second image: per-sample variance",
    "width": "film width",
    "height": "film height",
    "max_depth": "longest path, -1 for none (enables per-bounce localisation)",
    "defines": "scene parameters as -D name=value ...",
}
#: Placeholders a template must use: without them the images are not the ones asked for.
REQUIRED = ("spp", "seed", "out")


@dataclass(frozen=True)
class CommandTemplate:
    """A parsed ``--command`` template.

    Attributes
    ----------
    text : str
        The template as given.
    names : frozenset of str
        The placeholders it uses.
    """

    text: str
    names: frozenset

    @classmethod
    def parse(cls, text: str) -> CommandTemplate:
        """Parse ``text``; a malformed template or an unknown or missing placeholder is a
        one-line :class:`RefsInputError`."""
        if not text or not text.strip():
            raise RefsInputError("--command is empty; give the renderer's command line, e.g. "
                                 "'./render --spp {spp} --seed {seed} -o {out}'")
        try:
            fields = [field for _, field, spec, conv in string.Formatter().parse(text)
                      if field is not None]
            specs = [(field, spec, conv) for _, field, spec, conv in string.Formatter().parse(text)
                     if field is not None and (spec or conv)]
        except ValueError as error:
            raise RefsInputError(f"--command {text!r}: {error} (write {{{{ and }}}} for literal "
                                 "braces)") from None
        if specs:
            raise RefsInputError(f"--command: placeholder {{{specs[0][0]}}} may not carry a format "
                                 "or conversion (write it as {name})")
        unknown = sorted({f for f in fields if f not in PLACEHOLDERS})
        if unknown:
            raise RefsInputError(f"--command: unknown placeholder {{{unknown[0]}}}; known: "
                                 + " ".join(f"{{{name}}}" for name in PLACEHOLDERS))
        missing = [name for name in REQUIRED if name not in fields]
        if missing:
            raise RefsInputError(f"--command must use {{{missing[0]}}}: the harness chooses every "
                                 f"render's {missing[0]} (placeholders: "
                                 + " ".join(f"{{{name}}}" for name in PLACEHOLDERS) + ")")
        return cls(text, frozenset(fields))

    @property
    def takes_max_depth(self) -> bool:
        """Whether the renderer is told the path length (then bounces can be localised)."""
        return "max_depth" in self.names

    @property
    def writes_variance(self) -> bool:
        """Whether the renderer writes a separate per-sample variance image."""
        return "out_variance" in self.names

    def fill(self, values: dict) -> str:
        """The shell command with every placeholder replaced by its shell-quoted value.

        ``values["defines"]`` is a dict of scene parameters, expanded to ``-D name=value``
        words (less ``max_depth`` when the template passes ``{max_depth}``, which says it for
        every render, the per-bounce ones included); every other value is one word.
        """
        words = {}
        for name in self.names:
            value = values[name]
            if name == "defines":
                # Mitsuba refuses a parameter given twice ("unused parameters"), and a
                # per-bounce render's {max_depth} differs from the scene's.
                value = {k: v for k, v in value.items()
                         if not (k == "max_depth" and self.takes_max_depth)}
                words[name] = " ".join(f"-D {shlex.quote(f'{k}={v}')}" for k, v in value.items())
            else:
                words[name] = shlex.quote(str(value))
        return self.text.format(**words)
