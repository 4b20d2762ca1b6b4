// The login form goes back to the page that sent the reader here.
const params = new URLSearchParams(location.search);
document.getElementById("next").value = params.get("next") || "/";
document.getElementById("failed").hidden = !params.has("failed");
document.getElementById("token").focus();
