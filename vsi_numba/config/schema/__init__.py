"""The configuration schema, declared once (:mod:`.models`), and what is generated from it
(:mod:`.generate`: the JSON Schema, the key reference, the ``vsi init`` template)."""

from vsi_numba.config.schema._fields import keys_of, kinds_of
from vsi_numba.config.schema.models import VsiConfig

__all__ = ["VsiConfig", "keys_of", "kinds_of"]
