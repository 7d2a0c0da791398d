// A property the drone type does not offer.
package UnknownProperty

var D1 Quadcopter

func INIT() {
	WaitUntil(D1.Batery() < 20, SEQ_Land)
}

func SEQ_Land() {
	D1.Land()
}
