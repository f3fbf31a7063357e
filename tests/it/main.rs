mod compare;
mod output;
