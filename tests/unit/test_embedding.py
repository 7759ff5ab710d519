"""The offline MiniLM embedding function."""

from typing import Any

import numpy as np
import pytest

from robocog.server.memory import embedding
from robocog.server.memory.embedding import MiniLMEmbeddingFunction, embed


def _cos(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.dot(a, b))


def test_vectors_are_384d_unit_norm_float32() -> None:
    vectors = embed(["open the fridge", "put the mug in the sink"])
    assert vectors.shape == (2, 384)
    assert vectors.dtype == np.float32
    assert np.allclose(np.linalg.norm(vectors, axis=1), 1.0, atol=1e-5)


def test_similar_sentences_are_closer_than_unrelated() -> None:
    a, b, c = embed(["put away all the items into the shelf", "place the objects on the shelf", "what's the weather"])
    assert _cos(a, b) > _cos(a, c) + 0.3


def test_batch_equals_one_by_one() -> None:
    texts = ["open the fridge", "a much longer sentence about moving every red block onto the table", "hi"]
    batch = embed(texts)
    single = np.stack([embed([t])[0] for t in texts])
    assert np.allclose(batch, single, atol=1e-4)


def test_long_input_is_truncated_not_rejected() -> None:
    (vector,) = embed(["move the cup " * 400])
    assert np.isclose(np.linalg.norm(vector), 1.0, atol=1e-5)


def test_empty_list_gives_empty_array() -> None:
    assert embed([]).shape == (0, 384)


def test_sha256_mismatch_raises(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(embedding, "MODEL_SHA256", "0" * 64)
    monkeypatch.setattr(embedding, "_cache", embedding.OrderedDict())  # a text seen before needs no model
    with pytest.raises(RuntimeError, match=r"expected sha256 0{64}"):
        embed(["open the fridge"])


def test_missing_model_file_raises(tmp_path: Any) -> None:
    with pytest.raises(RuntimeError, match="not found"):
        embedding.verify_model(tmp_path / "model.onnx")


def test_chroma_embedding_function_round_trips_config() -> None:
    ef = MiniLMEmbeddingFunction()
    assert not ef.is_legacy()
    rebuilt = MiniLMEmbeddingFunction.build_from_config(ef.get_config())
    assert rebuilt.get_config() == ef.get_config()
    (vector,) = ef(["open the fridge"])
    assert np.allclose(vector, embed(["open the fridge"])[0])


def test_chroma_embedding_function_rejects_other_model_config() -> None:
    with pytest.raises(ValueError, match="embedded with"):
        MiniLMEmbeddingFunction.build_from_config({"model_id": "some-other-model"})


def test_a_text_embedded_again_comes_from_the_cache_which_stays_bounded(monkeypatch: pytest.MonkeyPatch) -> None:
    runs: list[list[str]] = []
    real = embedding._embed_batch

    def counted(session: Any, tokenizer: Any, names: Any, texts: list[str]) -> Any:
        runs.append(texts)
        return real(session, tokenizer, names, texts)

    monkeypatch.setattr(embedding, "_embed_batch", counted)
    monkeypatch.setattr(embedding, "_cache", embedding.OrderedDict())
    first = embed(["Put away all the items into the shelf.", "a new text"])
    again = embed(["a third text", "Put away all the items into the shelf."])
    assert runs == [["a new text", "Put away all the items into the shelf."], ["a third text"]]
    np.testing.assert_array_equal(again[1], first[0])
    monkeypatch.setattr(embedding, "CACHE_SIZE", 2)
    embed(["one", "two", "three"])
    assert list(embedding._cache) == ["two", "three"]
