"""JSON and YAML documents as users write them, with a key given twice in one object or mapping refused: both
formats leave duplicate keys to the reader (JSON) or forbid them (YAML) and Python's parsers keep the last one
silently, so a second ``"x"`` column or a second ``"kanayama"`` table replaced the first without a word."""

from __future__ import annotations

import functools
import json
import re
from typing import Any


class GivenTwice(ValueError):
    """A key given twice in one object or mapping; the message names it (and, in YAML, its second line)."""


#: A float as YAML 1.2 (and yaml-cpp, which map_server reads with) writes one: an exponent without a decimal point
#: (``1e-2``) too, which PyYAML's YAML 1.1 rules read as text.
FLOAT_12 = re.compile(r"^[-+]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][-+]?[0-9]+)$")


def _unique(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in pairs:
        if key in out:
            raise GivenTwice(f"field {key!r} is given twice in one object")
        out[key] = value
    return out


def load_json(text: str | bytes) -> Any:
    """``json.loads(text)``, refusing a key given twice in one object.

    Raises:
        GivenTwice: A key given twice.
        ValueError: Not JSON (:class:`json.JSONDecodeError`).
    """
    return json.loads(text, object_pairs_hook=_unique)


@functools.cache
def yaml_loader() -> Any:
    """PyYAML's safe loader refusing a key given twice in one mapping (:class:`GivenTwice`, naming its line), and
    reading ``1e-2`` as the number YAML 1.2 reads (:data:`FLOAT_12`; PyYAML's YAML 1.1 rules read it as text)."""
    import yaml  # loaded when a YAML document is read

    class UniqueKeys(yaml.SafeLoader):
        def construct_mapping(self, node: Any, deep: bool = False) -> dict[Any, Any]:
            seen: set[Any] = set()
            for key_node, _ in node.value:
                key = self.construct_object(key_node, deep=deep)
                if key in seen:
                    raise GivenTwice(f"field {key!r} is given twice (again on line {key_node.start_mark.line + 1})")
                seen.add(key)
            return super().construct_mapping(node, deep=deep)  # type: ignore[no-any-return]

    # the resolvers copied, lists too: PyYAML's add_implicit_resolver appends to the list the SafeLoader shares
    UniqueKeys.yaml_implicit_resolvers = {k: list(v) for k, v in yaml.SafeLoader.yaml_implicit_resolvers.items()}
    UniqueKeys.add_implicit_resolver("tag:yaml.org,2002:float", FLOAT_12, list("-+0123456789."))
    return UniqueKeys
