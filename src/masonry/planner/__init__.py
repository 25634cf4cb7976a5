
# Dispatcher and bounds (issue 5, dispatcher engineer).
from masonry.planner.dispatch import POLICIES, Assignment, Dispatcher  # noqa: E402
