import os

from hypothesis import HealthCheck, settings

# CI draws the same examples every run (a failure there is reproducible, never luck); the dev
# profile keeps exploring new ones
settings.register_profile(
    "ci",
    max_examples=60,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.register_profile("dev", max_examples=25, deadline=None)
settings.load_profile("ci" if os.environ.get("CI") else "dev")
