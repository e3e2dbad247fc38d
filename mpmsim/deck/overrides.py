"""Deck variants: a deck's data with dotted-key overrides, for method studies (bench/, tests).

    with_overrides(data, {"contact.normal": "average_gradient", "bodies.1.max": [1, 2]})

Numbers in a key index lists; missing mappings are created. The input is not modified.
"""

from __future__ import annotations

import copy


def with_overrides(data: dict, overrides: dict) -> dict:
    out = copy.deepcopy(data)
    for key, value in overrides.items():
        node = out
        *parents, last = key.split(".")
        for p in parents:
            node = node[int(p)] if isinstance(node, list) else node.setdefault(p, {})
        if isinstance(node, list):
            node[int(last)] = value
        else:
            node[last] = value
    return out
