"""The live view in a browser (`hand-service view`, docs/view.md): a process apart from the
daemon that reads its recording ring read-only and streams it to a page on loopback."""
