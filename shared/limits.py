"""Size limits of every text the server accepts, stores and returns, written down once.

Tool arguments carry them as `maxLength` in their input schemas (the SDK rejects a longer value
before any tool code runs) and the tools' descriptions state them. Episodic memory also cuts what it
stores and returns to them, so a record written before the limits existed cannot flood an answer.
"""

#: An object, location or place-position name, a task id.
NAME_CHARS = 200
#: An episode id a harness gives begin_task (its memory record's id derives from it).
EPISODE_ID_CHARS = 128
#: A search_memory query.
QUERY_CHARS = 2_000
#: end_task's description of the task (the embedded, searchable text of the record).
DESCRIPTION_CHARS = 2_000
#: end_task's summary of what was done and learned.
SUMMARY_CHARS = 4_000
#: One scratchpad note.
NOTE_CHARS = 2_000
#: Notes the scratchpad keeps, and their characters in all (the oldest are dropped past either).
SCRATCHPAD_NOTES = 50
SCRATCHPAD_CHARS = 8_000
#: Characters of task descriptions and summaries one search_memory answer returns in all; the
#: results that do not fit are left out (the answer says how many). With its JSON twice on the wire
#: (structured content and text), an answer stays under 64 KB.
SEARCH_ANSWER_CHARS = 24_000
#: Tokens of a text the embedding model reads: a task's instruction (about 45 words) and no more. Its
#: cost grows with the tokens (about 0.8 ms of CPU each here), so this bounds a search or an end_task
#: to about 50 ms of CPU whatever the text; MiniLM itself would read 256.
EMBED_TOKENS = 64
#: Characters of a text the tokenizer is given (well past `EMBED_TOKENS` tokens: it splits no more).
EMBED_CHARS = 1_000


def truncate(text: str, limit: int) -> str:
    """`text` if it has at most `limit` characters, else its start and a marker saying how long it was,
    `limit` characters in all (the marker alone when `limit` is shorter than it)."""
    if len(text) <= limit:
        return text
    marker = f" … [truncated, {len(text)} chars]"
    return text[: max(0, limit - len(marker))] + marker
