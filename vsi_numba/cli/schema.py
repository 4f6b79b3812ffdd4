"""``vsi schema``: the JSON Schema of a configuration file, for completion and checks in
TOML editors (taplo, Even Better TOML; docs/reference/configuration.md says how)."""

from __future__ import annotations

from pathlib import Path

from vsi_numba.cli.common import EXIT_USAGE, Printer


def schema_command(output: Path | None) -> int:
    """Print the shipped schema, or write it to ``output``; 2 when it cannot be written."""
    from vsi_numba.config.schema.generate import SCHEMA_FILE

    text = SCHEMA_FILE.read_text(encoding="utf-8")
    if output is None:
        print(text, end="")
        return 0
    from vsi_numba.io.atomic import describe, write_text_atomic
    from vsi_numba.io.paths import path_length_problem

    pr = Printer()
    problem = path_length_problem(Path(output), "schema", "choose a shorter name")
    if problem is not None:
        pr.error(problem)
        return EXIT_USAGE
    if Path(output).is_dir():
        pr.error(f"cannot write {output}: it is a directory; give a file name "
                 "(vsi schema -o FILE.json)")
        return EXIT_USAGE
    try:
        write_text_atomic(output, text)
    except OSError as exc:
        pr.error(f"cannot write {output}: {describe(exc)}; nothing was written (an "
                 "earlier file there is kept)")
        return EXIT_USAGE
    pr.line(f"wrote {output}: point a configuration at it with `#:schema {output}` on its "
            "first line (taplo, Even Better TOML)")
    return 0
