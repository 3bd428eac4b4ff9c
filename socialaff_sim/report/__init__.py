"""HTML reports of the demo and of an evaluation: one ``report.html`` beside the figures and videos it shows.

This package sits on top of the pipeline (it reads the demo's results and ``results.json``);
nothing below imports it.
"""

from .demo_page import DEMO_PAGE, write_demo_page
from .evaluation_page import EVALUATION_PAGE, write_evaluation_page

__all__ = ["DEMO_PAGE", "EVALUATION_PAGE", "write_demo_page", "write_evaluation_page"]
