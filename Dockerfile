# The brdffit HTTP service: FastAPI on uvicorn, jobs in SQLite under /data.
#   docker build -t brdffit .
#   docker run --rm -p 8000:8000 -v brdffit-data:/data -e BRDFFIT_API_TOKEN=<secret> brdffit
# It listens on every interface of the container, so it asks for an API token
# (clients send "Authorization: Bearer <secret>"; /health stays open) and refuses
# to start without one, unless told BRDFFIT_ALLOW_NO_TOKEN=1.
FROM python:3.11-slim

ENV PYTHONDONTWRITEBYTECODE=1 \
    PYTHONUNBUFFERED=1 \
    PIP_NO_CACHE_DIR=1 \
    PIP_DISABLE_PIP_VERSION_CHECK=1 \
    BRDFFIT_STORE_PATH=/data/jobs.sqlite3 \
    BRDFFIT_WORKERS=2

WORKDIR /app
# The package with the 'service' extra (FastAPI, uvicorn; no plotting or colour
# packages: the service uses neither). Every dependency ships wheels: nothing to compile.
COPY pyproject.toml README.md ./
COPY brdffit ./brdffit
COPY service ./service
RUN pip install '.[service]' \
    && useradd --create-home --uid 10001 brdffit \
    && mkdir -p /data \
    && chown brdffit:brdffit /data

USER brdffit
VOLUME ["/data"]
EXPOSE 8000

HEALTHCHECK --interval=30s --timeout=5s --start-period=30s --retries=3 \
    CMD ["python", "-c", "import sys, urllib.request; sys.exit(urllib.request.urlopen('http://127.0.0.1:8000/health', timeout=4).status != 200)"]

# One uvicorn process: it owns the job store (a lock beside it refuses a second
# server; it marks the jobs a previous run was running interrupted at start);
# BRDFFIT_WORKERS processes run the jobs.
CMD ["brdffit", "serve", "--host", "0.0.0.0", "--port", "8000"]
