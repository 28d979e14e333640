# SPDX-License-Identifier: Apache-2.0
# bash completion for rtm. Install: source this file, or copy it to
# /usr/share/bash-completion/completions/rtm.
_rtm_components() {
  rtm ls --names 2>/dev/null
}

_rtm_ports() {
  # <component>.<port> for every port of the component typed so far
  local comp=${1%.*}
  rtm cat --names "$comp" 2>/dev/null | sed "s/^/$comp./"
}

_rtm() {
  local cur prev words cword
  _init_completion 2>/dev/null || { cur=${COMP_WORDS[COMP_CWORD]}; prev=${COMP_WORDS[COMP_CWORD-1]}; cword=$COMP_CWORD; words=("${COMP_WORDS[@]}"); }
  local commands="ls cat set connect disconnect on off reset get put watch record play replay up down check names serve tls new demo script"
  local cmd="" i
  for ((i = 1; i < cword; i++)); do
    case ${words[i]} in
      --naming|--timeout|--tls) ((i++)) ;;
      -*) ;;
      *) cmd=${words[i]}; break ;;
    esac
  done
  [[ $prev == --tls ]] && { COMPREPLY=($(compgen -d -- "$cur")); return; }
  if [[ -z $cmd ]]; then
    if [[ $cur == -* ]]; then
      COMPREPLY=($(compgen -W "--naming --json --timeout --tls --help" -- "$cur"))
    else
      COMPREPLY=($(compgen -W "$commands" -- "$cur"))
    fi
    return
  fi
  case $cmd in
    ls)
      if [[ $cur == -* ]]; then
        COMPREPLY=($(compgen -W "-l --long --clean --names" -- "$cur"))
      else
        COMPREPLY=($(compgen -W "$(_rtm_components)" -- "$cur"))
      fi
      ;;
    cat|on|off|reset) COMPREPLY=($(compgen -W "$(_rtm_components)" -- "$cur")) ;;
    set)
      if [[ $prev == set ]]; then
        COMPREPLY=($(compgen -W "$(_rtm_components)" -- "$cur"))
      elif [[ ${words[cword-2]} == set ]]; then
        COMPREPLY=($(compgen -W "$(rtm cat --parameters "$prev" 2>/dev/null)" -- "$cur"))
      fi
      ;;
    connect|disconnect|get|put|watch)
      if [[ $cur == *.* ]]; then
        COMPREPLY=($(compgen -W "$(_rtm_ports "$cur")" -- "$cur"))
      else
        compopt -o nospace 2>/dev/null
        COMPREPLY=($(compgen -S . -W "$(_rtm_components)" -- "$cur"))
      fi
      [[ $cmd == watch && $cur == -* ]] && COMPREPLY=($(compgen -W "--rate --csv --count --duration" -- "$cur"))
      [[ $cmd == connect && $cur == -* ]] && COMPREPLY=($(compgen -W "--once --policy" -- "$cur"))
      [[ $cmd == put && $cur == -* ]] && COMPREPLY=($(compgen -W "--rate --for" -- "$cur"))
      ;;
    record)
      if [[ $cur == -* ]]; then
        COMPREPLY=($(compgen -W "-o --output --all --force --compression --duration --count --recover" -- "$cur"))
      elif [[ $prev == -o || $prev == --output || $prev == --recover ]]; then
        COMPREPLY=($(compgen -f -X '!*.mcap' -- "$cur"))
      elif [[ $cur == *.* ]]; then
        COMPREPLY=($(compgen -W "$(_rtm_ports "$cur")" -- "$cur"))
      else
        compopt -o nospace 2>/dev/null
        COMPREPLY=($(compgen -S . -W "$(_rtm_components)" -- "$cur"))
      fi
      ;;
    play)
      if [[ $cur == -* ]]; then
        COMPREPLY=($(compgen -W "--map --rate --loop --from --to --keep-stamps --spin-us" -- "$cur"))
      else
        COMPREPLY=($(compgen -f -X '!*.mcap' -- "$cur"))
      fi
      ;;
    replay)
      if [[ $cur == -* ]]; then
        COMPREPLY=($(compgen -W "-o --output --set --show" -- "$cur"))
      elif [[ $prev == replay ]]; then
        COMPREPLY=($(compgen -c -- "$cur" | grep '^rtm-'; compgen -f -- "$cur"))
      else
        COMPREPLY=($(compgen -f -X '!*.mcap' -- "$cur"))
      fi
      ;;
    up|down|check)
      if [[ $cmd == up && $cur == -* ]]; then
        COMPREPLY=($(compgen -W "--bind-timeout --set --force" -- "$cur"))
      else
        COMPREPLY=($(compgen -f -X '!*.@(yaml|yml)' -- "$cur"))
      fi
      ;;
    names) COMPREPLY=($(compgen -W "--stop" -- "$cur")) ;;
    demo) COMPREPLY=($(compgen -W "--bus --out --profile --system --duration --bin --check --realtime --no-realtime --help" -- "$cur")) ;;
    script)
      if [[ $cur == -* ]]; then
        COMPREPLY=($(compgen -W "--name --reference --wrench --pose --controller --help-script" -- "$cur"))
      elif [[ $prev == --reference || $prev == --wrench || $prev == --pose ]]; then
        if [[ $cur == *.* ]]; then
          COMPREPLY=($(compgen -W "$(_rtm_ports "$cur")" -- "$cur"))
        else
          compopt -o nospace 2>/dev/null
          COMPREPLY=($(compgen -S . -W "$(_rtm_components)" -- "$cur"))
        fi
      elif [[ $prev == --controller ]]; then
        COMPREPLY=($(compgen -W "$(_rtm_components)" -- "$cur"))
      else
        COMPREPLY=($(compgen -f -X '!*.py' -- "$cur"))
      fi
      ;;
    new)
      if [[ $prev == new ]]; then
        COMPREPLY=($(compgen -W "component" -- "$cur"))
      elif [[ $prev == --idl ]]; then
        COMPREPLY=($(compgen -f -X '!*.idl' -- "$cur"))
      elif [[ $cur == -* ]]; then
        COMPREPLY=($(compgen -W "--in --out --param --idl --types --period --description --dir --python" -- "$cur"))
      fi
      ;;
    tls)
      if [[ $prev == tls ]]; then
        COMPREPLY=($(compgen -W "init issue" -- "$cur"))
      elif [[ $cur == -* ]]; then
        COMPREPLY=($(compgen -W "--name --days --system" -- "$cur"))
      else
        COMPREPLY=($(compgen -d -- "$cur"))
      fi
      ;;
  esac
}
complete -F _rtm rtm
