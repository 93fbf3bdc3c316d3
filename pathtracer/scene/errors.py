"""The one exception type of the scene loader, with file/line/plugin context."""
from __future__ import annotations


class SceneError(ValueError):
    """A scene file that this tracer cannot render faithfully.

    The message always starts with where the problem is, so that a user can
    jump to it: ``cbox.xml:42: <bsdf type="plastic">: unsupported BSDF ...``.

    Parameters
    ----------
    message : str
        What is wrong and, where possible, how to fix it.
    file : str, optional
        Name of the scene (or mesh) file.
    line : int, optional
        1-based line number in ``file``.
    plugin : str, optional
        The offending element, e.g. ``'<bsdf type="plastic">'``.
    """

    def __init__(self, message: str, file: str | None = None,
                 line: int | None = None, plugin: str | None = None):
        self.file = file
        self.line = line
        self.plugin = plugin
        self.reason = message
        where = []
        if file is not None:
            where.append(f"{file}:{line}" if line is not None else file)
        if plugin:
            where.append(plugin)
        super().__init__(": ".join(where + [message]))
