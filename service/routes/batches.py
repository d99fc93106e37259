"""``POST /batches``: several uploaded files x several models, as jobs.

Every file is read and every (file, model) pair checked (one evaluation, as
``POST /jobs`` does) before any job is stored, so a batch is accepted whole
or refused whole with a 422 naming the file or the model at fault. Accepted,
each pair is an ordinary job (``GET /jobs/{id}``, ``DELETE``, resubmit) run
by the service's job runner: the process pool, or a Dask cluster
(``service/dask_runner.py``).
"""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, File, Form, UploadFile
from pydantic import BaseModel, Field

import brdffit

from ..convert import fit_kwargs, model_names, read_upload
from ..deps import RunnerDep, SettingsDep, StoreDep
from ..errors import ApiError
from ..schemas import JobOut
from ..store import data_to_bytes
from .common import (
    ERRORS,
    ChannelsField,
    FormatField,
    OptionsField,
    SubsampleField,
    form_options,
    stored_options,
)

__all__ = ["router", "MAX_PAIRS"]

#: Most pairs one batch may hold: a batch is stored before it is answered.
MAX_PAIRS = 1000

router = APIRouter(tags=["jobs"])


class BatchJobOut(BaseModel):
    """One pair of a batch and its job."""

    file: str = Field(description="The uploaded file's name.")
    model: str
    job: JobOut


class BatchOut(BaseModel):
    """The jobs of a batch, in order of the files, then of the models."""

    jobs: list[BatchJobOut]


FilesField = Annotated[list[UploadFile], File(description="The data files (as POST /jobs/file).")]
ModelsField = Annotated[str, Form(max_length=5000, description="Comma-separated model names.")]


def _read_all(limit: int, files, format, subsample, channels) -> list:
    out = []
    for i, upload in enumerate(files):
        data, notes = read_upload(upload.file.read(), upload.filename, format, subsample,
                                  channels, limit, field=f"files[{i}]")  # fmt: skip
        out.append((upload.filename or f"files[{i}]", data, notes))
    return out


BATCH_RESPONSES = {**ERRORS, 202: {"description": "Accepted: every job is stored."}}


@router.post("/batches", status_code=202, response_model=BatchOut, responses=BATCH_RESPONSES)
def create_batch(
    settings: SettingsDep,
    store: StoreDep,
    runner: RunnerDep,
    files: FilesField,
    models: ModelsField,
    format: FormatField = None,
    subsample: SubsampleField = None,
    channels: ChannelsField = None,
    options: OptionsField = "{}",
):
    """Queue ``brdffit.fit(read(file), model, **options)`` for every file x model."""
    names = model_names(models, MAX_PAIRS)
    if len(files) * len(names) > MAX_PAIRS:
        raise ApiError(422, f"{len(files)} files x {len(names)} models is more than "
                       f"{MAX_PAIRS} pairs; split the batch", "files")  # fmt: skip
    options_in = form_options(options)
    kwargs = fit_kwargs(options_in, settings.job_timeout)
    read = _read_all(settings.max_samples, files, format, subsample, channels)
    for _, data, _ in read:
        for name in names:
            brdffit.check_fit(data, name, **kwargs)  # bad input is a 422 now
    jobs = []
    for filename, data, notes in read:
        blob = data_to_bytes(data)
        for name in names:
            job = store.create(name, stored_options(kwargs, options_in.export), blob, notes)
            runner.submit(job["id"], job["attempt"])
            jobs.append({"file": filename, "model": name, "job": job})
    return {"jobs": jobs}
