"""What diagnose tells: the verdict, the evidence sentences and the HTML report."""
