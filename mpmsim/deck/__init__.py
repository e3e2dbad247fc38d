"""The problem deck: schema, loading with line-numbered errors, unit systems."""

from .loader import LoadedDeck, as_loaded_deck, load_deck, load_deck_text
from .schema import Deck

__all__ = ["Deck", "LoadedDeck", "as_loaded_deck", "load_deck", "load_deck_text"]
