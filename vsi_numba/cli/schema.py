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
    pr = Printer()
    try:
        Path(output).write_text(text, encoding="utf-8")
    except OSError as exc:
        pr.error(f"cannot write {output}: {exc.strerror or exc}")
        return EXIT_USAGE
    pr.line(f"wrote {output}: point a configuration at it with `#:schema {output}` on its "
            "first line (taplo, Even Better TOML)")
    return 0
