"""The scratchpad: bounded working memory for one episode."""

from __future__ import annotations

from collections import deque

from pydantic import BaseModel, Field

from robocog.shared.limits import NOTE_CHARS, SCRATCHPAD_CHARS, SCRATCHPAD_NOTES

#: The default bounds: at most this many entries, characters in all, and characters per entry.
MAX_ENTRIES = SCRATCHPAD_NOTES
MAX_CHARS = SCRATCHPAD_CHARS
MAX_ENTRY_CHARS = NOTE_CHARS


class ScratchpadAdd(BaseModel):
    """What :meth:`Scratchpad.add` did."""

    entries: int = Field(description="Number of entries now on the scratchpad.")
    dropped: int = Field(description="How many of the oldest entries were dropped to make room.")
    chars: int = Field(description="Total characters now on the scratchpad.")


class Scratchpad:
    """Notes kept during one episode; the oldest are dropped once a bound is reached."""

    def __init__(
        self, max_entries: int = MAX_ENTRIES, max_chars: int = MAX_CHARS, max_entry_chars: int = MAX_ENTRY_CHARS
    ) -> None:
        if max_entries < 1 or max_chars < 1 or max_entry_chars < 1:
            raise ValueError("scratchpad bounds must all be at least 1")
        if max_entry_chars > max_chars:
            raise ValueError(f"max_entry_chars ({max_entry_chars}) cannot exceed max_chars ({max_chars})")
        self.max_entries = max_entries
        self.max_chars = max_chars
        self.max_entry_chars = max_entry_chars
        self._entries: deque[str] = deque()
        self._chars = 0

    def add(self, text: str) -> ScratchpadAdd:
        """Append a note (surrounding whitespace stripped), dropping the oldest notes if needed."""
        if not isinstance(text, str) or not text.strip():
            raise ValueError("scratchpad text is empty: write the note to keep, e.g. 'the mug is in the sink'")
        note = text.strip()
        if len(note) > self.max_entry_chars:
            raise ValueError(
                f"scratchpad entry is {len(note)} characters, over the limit of {self.max_entry_chars}: "
                "shorten it or split it into several notes"
            )
        dropped = 0
        while self._entries and (len(self._entries) + 1 > self.max_entries or self._chars + len(note) > self.max_chars):
            self._chars -= len(self._entries.popleft())
            dropped += 1
        self._entries.append(note)
        self._chars += len(note)
        return ScratchpadAdd(entries=len(self._entries), dropped=dropped, chars=self._chars)

    def view(self) -> str:
        """All notes, oldest first, separated by blank lines ('' when empty)."""
        return "\n\n".join(self._entries)

    @property
    def entries(self) -> list[str]:
        """A copy of the notes, oldest first."""
        return list(self._entries)

    @property
    def chars(self) -> int:
        """Total characters of the notes (separators not counted)."""
        return self._chars

    def clear(self) -> None:
        """Remove every note."""
        self._entries.clear()
        self._chars = 0

    def __len__(self) -> int:
        return len(self._entries)
