"""MillBlocks: conversational mill programming (the web app arrives with the editor issue)."""
